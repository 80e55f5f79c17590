"""``blinkcan`` command line: one module per subcommand, registered here (:data:`SUBCOMMANDS`).

A subcommand's module is imported when that subcommand runs, not before: ``blinkcan --help``
and ``blinkcan decode`` do not load python-can's buses, the runtime, cantools or canopen that
other subcommands need (issue 22: start-up CPU). The listing of ``--help`` reads each
subcommand's one-line help from :data:`SUBCOMMANDS` (tests/cli check it is the command's own).

Every error ends the same way: one line on stderr and a non-zero exit (2 for a usage mistake,
1 otherwise); ``-vv`` adds the traceback of an unexpected one.
"""

from __future__ import annotations

import errno
import logging
import sys
from collections.abc import Sequence
from importlib import import_module
from typing import Any

import click

from blinkcan import __version__
from blinkcan.cli.answers import DeclinedError
from blinkcan.cli.bus_options import (
    bus_option_in,
    bus_options,
    given_bus_options,
    spread_bus_kwargs,
    takes_bus_options,
)
from blinkcan.cli.collector import collector_paused

log = logging.getLogger(__name__)

#: every subcommand: name -> ("module:attribute" of its click command, its one-line help as
#: its docstring starts); one line registers a subcommand
SUBCOMMANDS: dict[str, tuple[str, str]] = {
    "emulate": ("blinkcan.cli.emulate:command", "Run device twins on a CAN bus until Ctrl-C."),
    "act": ("blinkcan.cli.act:command", "Act on the devices of a running blinkcan emulate: "
            "press 3, 16h turn 1 -5, 0Ch blow-fuse 4, keybox power-cycle, help, list (what "
            "emulate reads on its input)."),
    "demo": ("blinkcan.cli.demo:command",
             "A controller on a keypad and a Keybox twin: key N toggles output N, shown live."),
    "decode": ("blinkcan.cli.decode:command", "Decode a log file (any python-can format, or "
               ".pcap) into what happened; with --parquet, any number of them into a dataset "
               "for SQL (blinkcan query)."),
    "export": ("blinkcan.cli.export:command", "Write the EDS or DBC file of a device, from the "
               "same tables the twins run on."),
    "convert": ("blinkcan.cli.convert:convert", "Convert a CAN log to another format (by file "
                "name), e.g. candump .log to .pcap."),
    "record": ("blinkcan.cli.convert:record", "Record a live bus to a file: .pcap for Wireshark, "
               "or any python-can log format."),
    "scan": ("blinkcan.cli.scan:command", "Find devices: boot-up and heartbeat heard, SDO read "
             "of 1000h, 1018h, 100Bh; keypads in J1939 mode by a software revision request and "
             "a request for address claimed, to all."),
    "monitor": ("blinkcan.cli.monitor:command", "Watch a bus live: events, keypad keys and "
                "LEDs (CANopen or J1939 mode), Keybox outputs, and what else a device sends "
                "(encoders, analog and digital inputs)."),
    "keypad": ("blinkcan.cli.control:keypad", "One-shot control of a keypad."),
    "keybox": ("blinkcan.cli.control:keybox", "One-shot control of a keybox."),
    "nmt": ("blinkcan.cli.nmt:command",
            "NMT commands (CiA 301) to a node, or to all of them with NODE = all."),
    "query": ("blinkcan.cli.query:command", "Run SQL on the dataset `blinkcan decode --parquet "
              "OUT` wrote: its rows are the table `events` (columns: time, source, channel, "
              "can_id, extended, node, kind, key, pin, state, colour, value, text, data, model, "
              "date)."),
}


#: why a command that opens no bus has none (said when bus options are given to it)
NO_BUS = {
    "act": " (it reaches a running blinkcan emulate through its socket; --to PID picks one)",
    "demo": " (its controller and devices share an in-process virtual bus)",
}


def load_subcommand(name: str) -> click.Command:
    """The click command of a registered subcommand, its module imported now."""
    module, _, attribute = SUBCOMMANDS[name][0].partition(":")
    with collector_paused():  # start-up: a module's objects are no garbage
        command = getattr(import_module(module), attribute)
    if not isinstance(command, click.Command):
        raise TypeError(f"{SUBCOMMANDS[name][0]} is a {type(command).__name__}, not a command")
    return command


class BlinkcanGroup(click.Group):
    """The root group: subcommands imported when they run, python-can's ``--bus-kwargs a=1
    b=2`` form, and one-line errors."""

    def list_commands(self, ctx: click.Context) -> list[str]:
        return sorted({*self.commands, *SUBCOMMANDS})

    def get_command(self, ctx: click.Context, cmd_name: str) -> click.Command | None:
        if cmd_name not in self.commands and cmd_name in SUBCOMMANDS:
            self.add_command(load_subcommand(cmd_name), cmd_name)
        return self.commands.get(cmd_name)

    def format_commands(self, ctx: click.Context, formatter: click.HelpFormatter) -> None:
        """click's listing, with the one-line help of subcommands not imported from
        :data:`SUBCOMMANDS` (the same text: click shortens both the same way)."""
        listed = [(name, self.commands.get(name) or click.Command(name, help=SUBCOMMANDS[name][1]))
                  for name in self.list_commands(ctx)]
        listed = [(name, command) for name, command in listed if not command.hidden]
        if not listed:
            return
        limit = formatter.width - 6 - max(len(name) for name, _ in listed)
        with formatter.section("Commands"):
            formatter.write_dl([(name, command.get_short_help_str(limit))
                                for name, command in listed])

    def parse_args(self, ctx: click.Context, args: list[str]) -> list[str]:
        return super().parse_args(ctx, spread_bus_kwargs(args))

    def resolve_command(self, ctx: click.Context, args: list[str]
                        ) -> tuple[str | None, click.Command | None, list[str]]:
        """The subcommand; a command that opens no bus refuses the bus options, before or
        after it, in one line (they were taken in silence, or, after ``act``'s words, sent
        to the emulator as words)."""
        name, command, rest = super().resolve_command(ctx, args)
        if command is not None and not takes_bus_options(command):
            given = given_bus_options(ctx)
            after = bus_option_in(rest)
            if after is not None:
                given.append(after)
            if given:
                why = NO_BUS.get(command.name or "", "")
                raise click.UsageError(f"blinkcan {name} opens no bus: {', '.join(given)} "
                                       f"do{'es' if len(given) == 1 else ''} not apply{why}",
                                       ctx)
        return name, command, rest

    def main(self, args: Sequence[str] | None = None, prog_name: str | None = None,
             complete_var: str | None = None, standalone_mode: bool = True,
             **extra: Any) -> Any:
        if not standalone_mode:
            return super().main(args, prog_name, complete_var, standalone_mode, **extra)
        try:
            result = super().main(args, prog_name, complete_var, False, **extra)
        except click.exceptions.NoArgsIsHelpError as error:
            click.echo(error.format_message())
            sys.exit(error.exit_code)
        except click.UsageError as error:
            hint = f" (see '{error.ctx.command_path} -h')" if error.ctx is not None else ""
            _fail(f"{error.format_message()}{hint}", error.exit_code)
        except click.ClickException as error:
            _fail(error.format_message(), error.exit_code)
        except DeclinedError as declined:  # "n" to a question is an answer, not an error
            click.echo(f"{declined}: nothing changed", err=True)
            sys.exit(0)
        except click.Abort as abort:
            if isinstance(abort.__context__, KeyboardInterrupt):
                _interrupted()
            _fail("aborted (no answer to the question: --yes answers it)", 1)
        except KeyboardInterrupt:
            _interrupted()
        except OSError as error:
            _fail(_os_error(error), 1)
        except Exception as error:  # one line for the user, the trace with -vv
            log.debug("unexpected error", exc_info=True)
            _fail(f"unexpected {type(error).__name__}: {error} (-vv shows the traceback)", 1)
        sys.exit(result if isinstance(result, int) else 0)


def _os_error(error: OSError) -> str:
    """One line for an OSError: the file it names, else what a nameless one is (a full disk
    under the output: standard output, or a pipe)."""
    if error.filename:
        return f"cannot use {error.filename}: {error.strerror or error}"
    if error.errno in _NO_ROOM:
        return f"cannot write the output: {error.strerror or error}"
    return f"{error.strerror or error}"


#: errors of a write that found no room (a full disk, a quota, a file size limit)
_NO_ROOM = frozenset({errno.ENOSPC, errno.EDQUOT, errno.EFBIG})


def _interrupted() -> None:
    """Ctrl-C is how a user stops a command: no error, the shell's code for SIGINT."""
    click.echo("interrupted", err=True)
    sys.exit(130)


def _fail(message: str, code: int) -> None:
    click.echo(f"Error: {message}", err=True)
    sys.exit(code)


@click.group(cls=BlinkcanGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="blinkcan")
@click.option("-v", "--verbose", count=True, help="More log output (-vv for debug).")
@bus_options
def cli(verbose: int) -> None:
    """Digital twins, drivers and decoders for Blink Marine keypads (CANopen, J1939) and Keyboxes.

    Bus options (-i, -c, -b, --bus-kwargs) go before or after the command. With none given and
    none configured for python-can: udp_multicast 239.74.163.2:43113, hop limit 0 (processes of
    this machine only).
    """
    level = logging.WARNING - 10 * verbose
    logging.basicConfig(level=max(level, logging.DEBUG),
                        format="%(levelname)s %(name)s: %(message)s")



def main() -> None:
    cli(prog_name="blinkcan")
