"""``blinkcan act COMMAND...``: act on the devices of a ``blinkcan emulate`` running in another
terminal, with the commands it reads on its input (cli/typed_commands.py), over its local
socket (cli/command_socket.py)."""

from __future__ import annotations

from collections.abc import Mapping

import click

from blinkcan.cli.command_socket import SocketError, emulators, send
from blinkcan.cli.typed_commands import MAX_LINE
from blinkcan.cli.whole import Whole

#: the largest process id Linux gives (PID_MAX_LIMIT, 2**22)
PID_MAX = 2**22


@click.command("act", context_settings={"ignore_unknown_options": True,
                                        "allow_interspersed_args": False})
@click.argument("words", nargs=-1, required=True, metavar="COMMAND...")
@click.option("--to", "pid", type=Whole(1, PID_MAX), default=None, metavar="PID",
              help="The emulator's process id, when several run.")
def command(words: tuple[str, ...], pid: int | None) -> None:
    """Act on the devices of a running blinkcan emulate: press 3, 16h turn 1 -5,
    0Ch blow-fuse 4, keybox power-cycle, help, list (what emulate reads on its input).

    \b
    blinkcan act 15h tap 3
    blinkcan act --to 4242 0Ch blow-fuse 4
    """
    line = _line(words)
    try:
        running = emulators()
        if pid is not None and pid not in running:
            raise click.ClickException(f"no blinkcan emulate of this user has process id {pid}"
                                       f"; running: {_pids(running) or 'none'}")
        if pid is None and not running:
            raise click.ClickException("no blinkcan emulate of this user runs on this machine "
                                       "(start one: blinkcan emulate keypad)")
        if pid is None and len(running) > 1:
            described = "; ".join(f"{number}: {', '.join(send(path, 'list'))}"
                                  for number, path in running.items())
            raise click.UsageError(f"{len(running)} emulators run ({described}); pick one "
                                   "with --to PID")
        path = running[pid] if pid is not None else next(iter(running.values()))
        answer = send(path, line)
    except (SocketError, OSError) as error:
        raise click.ClickException(f"cannot reach the emulator: {error}") from None
    failed = False
    for line in answer:
        failed = failed or line.startswith("Error: ")
        click.echo(line, err=line.startswith("Error: "))
    if failed:
        raise SystemExit(1)


def _line(words: tuple[str, ...]) -> str:
    """The one line ``words`` make, checked before any emulator is asked (a usage error
    otherwise); a byte of the command line that is not UTF-8 (kept by Python as a surrogate)
    becomes U+FFFD, so the emulator names it as a bad argument."""
    line = " ".join(words).encode(errors="surrogateescape").decode(errors="replace")
    if "\n" in line or "\r" in line:
        raise click.UsageError("act sends one command line; several go down emulate's input "
                               "(printf '...\\n...' | blinkcan emulate ...) or as several acts")
    if len(line.encode()) > MAX_LINE:
        raise click.UsageError(f"one command line of at most {MAX_LINE} bytes")
    return line


def _pids(running: Mapping[int, object]) -> str:
    return ", ".join(str(number) for number in running)
