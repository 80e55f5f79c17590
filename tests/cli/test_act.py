"""``blinkcan act`` reaches a running ``blinkcan emulate`` over its private Unix socket
(issue 20 item 11): the socket is the user's alone (directory 0700, socket 0600), a dead
emulator's socket is removed, several emulators are told apart by process id."""

from __future__ import annotations

import io
import os
import random
import signal
import socket
import stat
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import can
import pytest
from click.testing import CliRunner
from rich.console import Console

from blinkcan.cli.command_socket import (
    SocketError,
    command_socket,
    emulators,
    runtime_dir,
    send,
    supported,
)
from blinkcan.cli.emulate import build_twins
from blinkcan.cli.main import cli
from blinkcan.cli.typed_commands import MAX_LINE, TypedCommands
from blinkcan.runtime import Emulator
from tests.processes import stop

pytestmark = pytest.mark.skipif(not supported(), reason="no Unix sockets here")


@pytest.fixture
def private_dir(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    monkeypatch.setenv("XDG_RUNTIME_DIR", str(tmp_path))
    return tmp_path / "blinkcan"


@pytest.fixture
def live_emulator() -> Iterator[Emulator]:
    bus = can.Bus(interface="virtual", channel=f"act-{random.getrandbits(48):x}")
    with Emulator(bus, build_twins(("keypad", "keybox"), None, None, "firmware")) as emulator:
        yield emulator
    bus.shutdown()


def _act(*words: str) -> tuple[int, str, str]:
    result = CliRunner().invoke(cli, ["act", *words])
    return result.exit_code, result.stdout, result.stderr


def test_act_reaches_the_emulator_on_a_socket_only_its_user_can_use(
        private_dir: Path, live_emulator: Emulator) -> None:
    output = io.StringIO()
    with command_socket(TypedCommands(live_emulator), Console(file=output)) as path:
        assert path is not None
        assert stat.S_IMODE(private_dir.stat().st_mode) == 0o700
        assert stat.S_IMODE(path.lstat().st_mode) == 0o600
        assert emulators() == {os.getpid(): path}
        assert _act("15h", "press", "3") == (0, "PKP-2600-SI keypad 15h: press key 3\n", "")
        code, _, errors = _act("turn", "1", "-5")  # a negative number is no option
        assert code == 1
        assert errors.startswith("Error: no emulated device has 'turn'")
        assert send(path, "x" * MAX_LINE)[0].startswith("Error: unknown command or device")
        with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as client:  # too long
            client.connect(str(path))
            client.sendall(b"y" * (MAX_LINE + 10) + b"\n")
            client.shutdown(socket.SHUT_WR)
            assert client.recv(4096).startswith(b"Error: send one command line")
        keypad = live_emulator.twins[0]
        assert live_emulator.snapshot(keypad)["keys"][2]["pressed"]
    assert not path.exists()  # removed when the emulator stops
    assert output.getvalue() == ""


def test_a_dead_emulators_socket_is_removed_and_said(private_dir: Path) -> None:
    private_dir.mkdir(mode=0o700)
    stale = private_dir / "emulate-99999999.sock"
    with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as dead:
        dead.bind(str(stale))  # bound, never listening: as a process killed left it
    assert emulators() == {}
    assert not stale.exists()
    code, _, errors = _act("press", "3")
    assert code == 1
    assert errors == ("Error: no blinkcan emulate of this user runs on this machine (start one:"
                      " blinkcan emulate keypad)\n")


def test_a_directory_others_may_enter_is_refused(private_dir: Path,
                                                  live_emulator: Emulator) -> None:
    private_dir.mkdir(mode=0o755)
    private_dir.chmod(0o755)
    with pytest.raises(SocketError, match="not a directory private to this user"):
        runtime_dir()
    output = io.StringIO()
    with command_socket(TypedCommands(live_emulator), Console(file=output)) as path:
        assert path is None  # the emulator runs on without it, and says so
    assert output.getvalue().startswith("warning: blinkcan act cannot reach this emulator:")
    assert list(private_dir.iterdir()) == []
    code, _, errors = _act("press", "3")
    assert code == 1
    assert "not a directory private to this user" in errors


def _child_emulator(private_dir: Path, device: str) -> subprocess.Popen[str]:
    """``blinkcan emulate DEVICE`` in a child process on a udp_multicast bus of its own, its
    socket in ``private_dir``; returned once it listens there (its stdout a pipe)."""
    channel = f"239.74.{random.randint(1, 254)}.{random.randint(1, 254)}"
    environment = {**{k: v for k, v in os.environ.items() if not k.startswith("CAN_")},
                   "XDG_RUNTIME_DIR": str(private_dir.parent), "PYTHONUNBUFFERED": "1"}
    child = subprocess.Popen(
        [sys.executable, "-m", "blinkcan", "emulate", device, "-q", "-i",
         "udp_multicast", "-c", channel, "--bus-kwargs", f"port={random.randint(40000, 60000)}",
         "hop_limit=0"], stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT, text=True, env=environment)
    deadline = time.monotonic() + 120  # generous: 8 test suites may share 2 cores
    try:
        while child.pid not in emulators():
            assert child.poll() is None, child.communicate()[0]
            assert time.monotonic() < deadline, "the child's socket did not appear"
            time.sleep(0.05)
    except BaseException:
        stop(child)
        raise
    return child


@pytest.mark.multiprocess
def test_two_emulators_are_told_apart_by_process_id(private_dir: Path,
                                                    live_emulator: Emulator) -> None:
    child = _child_emulator(private_dir, "pkp-3500-mt")
    try:
        with command_socket(TypedCommands(live_emulator), Console(file=io.StringIO())):
            code, _, errors = _act("press", "3")
            assert code == 2
            assert f"{os.getpid()}: PKP-2600-SI keypad 15h" in errors
            assert f"{child.pid}: PKP-3500-MT keypad 15h, manual rev 1.3" in errors
            assert errors.startswith("Error: 2 emulators run (")
            assert "pick one with --to PID" in errors
            assert _act("--to", str(child.pid), "turn", "1", "-5") == (
                0, "PKP-3500-MT keypad 15h: turn encoder 1, ticks -5\n", "")
            assert _act("--to", str(os.getpid()), "0Ch", "blow-fuse", "4") == (
                0, "Keybox 0Ch: blow-fuse pin 4\n", "")
            code, _, errors = _act("--to", "1", "list")
            assert code == 1
            assert "no blinkcan emulate of this user has process id 1" in errors
    finally:
        stop(child)


@pytest.mark.multiprocess
@pytest.mark.parametrize("stop_signal", [signal.SIGTERM, signal.SIGINT, signal.SIGHUP],
                         ids=lambda number: signal.Signals(number).name)
def test_an_emulator_stopped_by_a_signal_removes_its_socket(private_dir: Path,
                                                            stop_signal: int) -> None:
    """SIGTERM (kill, a service manager) and SIGHUP (the terminal closed) stop it as Ctrl-C
    does: the socket goes, the bus is shut down, it says it stopped (SIGTERM left the socket)."""
    child = _child_emulator(private_dir, "keypad")
    path = emulators()[child.pid]
    try:
        child.send_signal(stop_signal)
        output, _ = child.communicate(timeout=60)
    finally:
        stop(child)
    assert child.returncode == 0, output
    assert output.rstrip().endswith("stopped")
    assert not path.exists()
    assert list(private_dir.iterdir()) == []


def test_several_clients_are_served_at_once(private_dir: Path, live_emulator: Emulator,
                                            monkeypatch: pytest.MonkeyPatch) -> None:
    """A client that has not sent its line yet (or waits on ``wait 10``) holds no other up."""
    monkeypatch.setattr("blinkcan.cli.command_socket.LINE_TIMEOUT_S", 300.0)
    with command_socket(TypedCommands(live_emulator), Console(file=io.StringIO())) as path:
        assert path is not None
        with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as slow:
            slow.connect(str(path))  # says nothing yet
            assert send(path, "15h press 3", timeout=60) == ["PKP-2600-SI keypad 15h: press key 3"]
            assert send(path, "list", timeout=60)[0].startswith("PKP-2600-SI keypad 15h")
            slow.sendall(b"15h release 3\n")
            slow.shutdown(socket.SHUT_WR)
            assert slow.recv(4096) == b"PKP-2600-SI keypad 15h: release key 3\n"


def test_one_client_more_than_it_serves_is_told_the_emulator_is_busy(
        private_dir: Path, live_emulator: Emulator, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr("blinkcan.cli.command_socket.LINE_TIMEOUT_S", 300.0)
    monkeypatch.setattr("blinkcan.cli.command_socket.MAX_CLIENTS", 1)
    with command_socket(TypedCommands(live_emulator), Console(file=io.StringIO())) as path:
        assert path is not None
        with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as slow:
            slow.connect(str(path))  # accepted first: it holds the one place
            assert send(path, "list", timeout=60) == [
                "Error: the emulator is busy with another command; try again when one has ended"]
            slow.sendall(b"list\n")
            slow.shutdown(socket.SHUT_WR)
            assert slow.recv(4096).startswith(b"PKP-2600-SI keypad 15h")
        # the place is free again once the answer came
        assert send(path, "list", timeout=60)[0].startswith("PKP-2600-SI keypad 15h")
        code, out, errors = _act("list")  # act's own probe takes a place for an instant too
        assert code == 0, (out, errors)


def test_a_socket_someone_listens_on_is_not_taken_over(private_dir: Path,
                                                       live_emulator: Emulator) -> None:
    """Under this process id's name but listened on: left alone, the emulator runs without."""
    private_dir.mkdir(mode=0o700)
    taken = private_dir / f"emulate-{os.getpid()}.sock"
    with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as listener:
        listener.bind(str(taken))
        listener.listen()
        output = io.StringIO()
        with command_socket(TypedCommands(live_emulator), Console(file=output)) as path:
            assert path is None
        assert output.getvalue().startswith("warning: blinkcan act cannot reach this emulator:")
        assert "another process listens on it" in output.getvalue()
        assert taken.exists()
        with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as client:
            client.connect(str(taken))  # still the listener's
            accepted, _ = listener.accept()
            accepted.close()


def test_a_stale_socket_under_this_process_id_is_replaced(private_dir: Path,
                                                          live_emulator: Emulator) -> None:
    """Left by a killed process that had this id (nobody listens): this emulator takes it."""
    private_dir.mkdir(mode=0o700)
    stale = private_dir / f"emulate-{os.getpid()}.sock"
    with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as dead:
        dead.bind(str(stale))
    with command_socket(TypedCommands(live_emulator), Console(file=io.StringIO())) as path:
        assert path == stale
        assert send(path, "15h press 3", timeout=60) == ["PKP-2600-SI keypad 15h: press key 3"]
    assert not stale.exists()


def test_a_socket_of_a_process_still_alive_is_left_alone(private_dir: Path) -> None:
    """Refused, but its process lives (an emulator between bind and listen): not removed."""
    private_dir.mkdir(mode=0o700)
    starting = private_dir / f"emulate-{os.getpid()}.sock"
    with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as not_yet:
        not_yet.bind(str(starting))
        assert emulators() == {}
        assert starting.exists()


@pytest.mark.parametrize("step", ["chmod", "listen", "thread"])
def test_a_stop_while_the_socket_is_being_set_up_removes_it(
        private_dir: Path, live_emulator: Emulator, monkeypatch: pytest.MonkeyPatch,
        step: str) -> None:
    """A stop signal (KeyboardInterrupt) between the socket's bind and its use left the file:
    ``act`` lists an emulator as soon as its socket exists, so a SIGHUP sent then stopped the
    emulator cleanly yet left the socket (the SIGHUP test failed under load; found by the
    attack pass of session 5)."""
    def interrupted(*args: object, **kwargs: object) -> None:
        raise KeyboardInterrupt

    target = {"chmod": (Path, "chmod"), "listen": (socket.socket, "listen"),
              "thread": (threading.Thread, "start")}[step]
    monkeypatch.setattr(*target, interrupted)
    with pytest.raises(KeyboardInterrupt), \
            command_socket(TypedCommands(live_emulator), Console(file=io.StringIO())):
        pass
    monkeypatch.undo()
    assert list(private_dir.iterdir()) == []


@pytest.mark.parametrize(("words", "said"), [
    (("15h", "press", "\udcff"), "key must be 1..12"),   # argv's escape of a byte not UTF-8
    (("15h press 3\n15h press 4",), "one command line"),  # two lines: a script is emulate's
    (("x" * (MAX_LINE + 1),), f"at most {MAX_LINE} bytes"),
])
def test_a_line_act_cannot_send_as_it_is_is_one_error_line(
        private_dir: Path, live_emulator: Emulator, words: tuple[str, ...], said: str) -> None:
    """A byte that is not UTF-8 was "unexpected UnicodeEncodeError"; a newline or a line too
    long was "cannot reach the emulator", which was running."""
    with command_socket(TypedCommands(live_emulator), Console(file=io.StringIO())):
        code, out, errors = _act(*words)
    assert code in (1, 2)
    assert out == ""
    assert errors.startswith("Error: "), errors
    assert errors.count("\n") == 1, errors
    assert said in errors
    assert "unexpected" not in errors
    assert "cannot reach" not in errors
    assert not any(key["pressed"]
                   for key in live_emulator.snapshot(live_emulator.twins[0])["keys"])
