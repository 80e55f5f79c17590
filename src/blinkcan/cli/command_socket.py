"""The typed commands of a running ``blinkcan emulate``, reachable from another terminal
(``blinkcan act``) over a local Unix socket.

Each emulator listens on ``emulate-PID.sock`` in a directory only its user can enter
(``$XDG_RUNTIME_DIR/blinkcan``, else ``blinkcan-UID`` in the temporary directory; created 0700,
refused if it belongs to someone else or others may write to it); the socket itself is 0600.
A client sends one command line and reads the lines the emulator answers until it closes.
Several clients are served at once (one's ``wait 10`` holds no other up), up to
:data:`MAX_CLIENTS`; one more waits up to :data:`PLACE_WAIT_S` for a place (a place is also
taken for an instant by a client's check that the emulator listens), then is answered that the
emulator is busy.
A socket left by an emulator that died (nobody accepts on it, and no process has its id) is
stale and is removed by the next client that meets it; an emulator removes its own when it
stops (Ctrl-C, SIGTERM: ``blinkcan emulate`` turns it into the same stop), and a new one takes
over a socket left under its own process id only if nobody listens on it (a ``kill -9``).
"""

from __future__ import annotations

import contextlib
import os
import re
import socket
import stat
import tempfile
import threading
from collections.abc import Callable, Iterator
from pathlib import Path

from rich.console import Console

from blinkcan.cli.typed_commands import MAX_LINE, TypedCommands
from blinkcan.errors import BlinkcanError

#: seconds a client may take to send its line, and an answer to come (``wait`` counts)
LINE_TIMEOUT_S = 5.0
ANSWER_TIMEOUT_S = 600.0
#: clients served at once; one more is told the emulator is busy
MAX_CLIENTS = 16
#: seconds a client beyond them waits for a place before it is told so (as many may wait)
PLACE_WAIT_S = 0.5
_ACCEPT_POLL_S = 0.25
_SOCKET_NAME = re.compile(r"emulate-(\d+)\.sock")


class SocketError(BlinkcanError, OSError):
    """No emulator to talk to, or one that cannot be reached safely."""


def runtime_dir(create: bool = True) -> Path:
    """The private directory the emulators' sockets live in (SocketError if it is not
    private to this user)."""
    base = os.environ.get("XDG_RUNTIME_DIR")
    path = (Path(base) / "blinkcan" if base
            else Path(tempfile.gettempdir()) / f"blinkcan-{os.getuid()}")
    if create:
        with contextlib.suppress(FileExistsError):
            path.mkdir(mode=0o700)
    try:
        info = path.lstat()
    except FileNotFoundError:
        return path
    if not stat.S_ISDIR(info.st_mode) or info.st_uid != os.getuid() \
            or info.st_mode & (stat.S_IRWXG | stat.S_IRWXO):
        raise SocketError(f"{path} is not a directory private to this user (owner only, "
                          "mode 0700): not used for the emulator's command socket")
    return path


def supported() -> bool:
    return hasattr(socket, "AF_UNIX") and hasattr(os, "getuid")


@contextlib.contextmanager
def command_socket(commands: TypedCommands, console: Console) -> Iterator[Path | None]:
    """While the body runs, answer ``blinkcan act`` on this process's socket (its path; None
    where the platform has no Unix sockets or no private place for one: a warning says so,
    and the emulator runs on)."""
    if not supported():
        yield None
        return
    server = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    stopping = threading.Event()
    thread = threading.Thread(target=_serve, args=(server, commands, stopping),
                              name="blinkcan-command-socket", daemon=True)
    bound: Path | None = None  # ours to remove, however the emulator stops (even starting)
    try:
        try:
            path = runtime_dir() / f"emulate-{os.getpid()}.sock"
            if _listening(path):
                raise SocketError(f"{path} is in use: another process listens on it")
            path.unlink(missing_ok=True)  # this process id's, nobody listening: an earlier one's
            server.bind(str(path))  # in the 0700 directory: no one else reaches it meanwhile
            bound = path
            path.chmod(0o600)
            server.listen()
            server.settimeout(_ACCEPT_POLL_S)
        except OSError as error:
            console.print(f"warning: blinkcan act cannot reach this emulator: {error}",
                          markup=False, highlight=False)
            yield None
            return
        thread.start()  # (a stop signal may come while it starts: the socket still goes)
        yield path
    finally:
        stopping.set()
        if thread.is_alive():
            thread.join(timeout=2 * _ACCEPT_POLL_S + 1)
        server.close()
        if bound is not None:
            bound.unlink(missing_ok=True)


def _serve(server: socket.socket, commands: TypedCommands, stopping: threading.Event) -> None:
    """Accepts clients until stopped, each answered in a thread of its own: up to
    :data:`MAX_CLIENTS` at once are served, one more is answered that the emulator is busy."""
    slots = threading.BoundedSemaphore(MAX_CLIENTS)
    waiting = threading.BoundedSemaphore(MAX_CLIENTS)  # clients waiting for a place
    others = "another command" if MAX_CLIENTS == 1 else f"{MAX_CLIENTS} other commands"
    busy = [f"Error: the emulator is busy with {others}; try again when "
            "one has ended"]

    def wait_for_place() -> bool:
        try:
            return slots.acquire(timeout=PLACE_WAIT_S)
        finally:
            waiting.release()

    while not stopping.is_set():
        try:
            connection, _ = server.accept()
        except TimeoutError:
            continue
        except OSError:
            return
        if slots.acquire(blocking=False):
            place: Callable[[], bool] = lambda: True  # noqa: E731
        elif waiting.acquire(blocking=False):
            place = wait_for_place
        else:
            place = lambda: False  # noqa: E731
        threading.Thread(target=_answer_in_place, name="blinkcan-command-client", daemon=True,
                         args=(connection, place, commands.execute, slots.release,
                               busy)).start()


def _answer_in_place(connection: socket.socket, place: Callable[[], bool],
                     reply: Callable[[str], list[str]], done: Callable[[], None],
                     busy: list[str]) -> None:
    """A client answered once it has a place (``place()``), else told the emulator is busy."""
    if place():
        _answer(connection, reply, done)
    else:
        _answer(connection, lambda _: busy, lambda: None)


def _answer(connection: socket.socket, reply: Callable[[str], list[str]],
            done: Callable[[], None]) -> None:
    """One client: its line read (all of it, so that closing resets nothing), the reply sent,
    the connection closed."""
    with connection:
        try:
            try:
                connection.settimeout(LINE_TIMEOUT_S)
                line = _read_line(connection)
                answer = (reply(line.decode(errors="replace")) if line is not None
                          else [f"Error: send one command line of at most {MAX_LINE} bytes"])
            finally:
                done()  # before the answer goes: a client that has it may ask again at once
            connection.sendall("".join(f"{text}\n" for text in answer).encode())
        except OSError:  # a client gone, or too slow
            pass


def _read_line(connection: socket.socket) -> bytes | None:
    data = b""
    while b"\n" not in data:
        chunk = connection.recv(MAX_LINE + 1)
        if not chunk:
            break
        data += chunk
        if len(data) > MAX_LINE + 1:
            return None
    line = data.partition(b"\n")[0]
    return None if len(line) > MAX_LINE else line


def emulators() -> dict[int, Path]:
    """The running emulators of this user, by process id; stale sockets are removed."""
    if not supported():
        raise SocketError("this platform has no Unix sockets: type the commands into "
                          "blinkcan emulate itself")
    directory = runtime_dir(create=False)
    found: dict[int, Path] = {}
    if not directory.is_dir():
        return found
    for path in sorted(directory.iterdir()):
        match = _SOCKET_NAME.fullmatch(path.name)
        if match is None:
            continue
        try:
            with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as probe:
                probe.settimeout(LINE_TIMEOUT_S)
                probe.connect(str(path))
        except (ConnectionRefusedError, FileNotFoundError):
            if not _alive(int(match.group(1))):  # (alive: it may be starting to listen)
                path.unlink(missing_ok=True)  # nobody listens: an emulator that died
            continue
        except OSError:
            continue
        found[int(match.group(1))] = path
    return dict(sorted(found.items()))  # by number: 9956 before 10588


def _listening(path: Path) -> bool:
    """Whether a process accepts connections on the socket at ``path``."""
    with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as probe:
        probe.settimeout(LINE_TIMEOUT_S)
        try:
            probe.connect(str(path))
        except (ConnectionRefusedError, FileNotFoundError):
            return False
        except OSError:  # a listener too busy to accept in time, or one not ours to reach
            return True
    return True


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)  # signal 0: only asks whether the process exists
    except ProcessLookupError:
        return False
    except OSError:  # it exists, someone else's
        return True
    return True


def send(path: Path, line: str, timeout: float = ANSWER_TIMEOUT_S) -> list[str]:
    """Send one command line to the emulator at ``path``; the lines it answers."""
    if "\n" in line or len(line.encode()) > MAX_LINE:
        raise SocketError(f"one command line of at most {MAX_LINE} bytes")
    with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as client:
        client.settimeout(timeout)
        client.connect(str(path))
        client.sendall(f"{line}\n".encode())
        client.shutdown(socket.SHUT_WR)
        data = b""
        while chunk := client.recv(65536):
            data += chunk
    return data.decode(errors="replace").splitlines()
