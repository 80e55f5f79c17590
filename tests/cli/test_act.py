"""``blinkcan act`` reaches a running ``blinkcan emulate`` over its private Unix socket
(issue 20 item 11): the socket is the user's alone (directory 0700, socket 0600), a dead
emulator's socket is removed, several emulators are told apart by process id."""

from __future__ import annotations

import io
import os
import random
import socket
import stat
import subprocess
import sys
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


@pytest.mark.multiprocess
def test_two_emulators_are_told_apart_by_process_id(private_dir: Path,
                                                    live_emulator: Emulator) -> None:
    channel = f"239.74.{random.randint(1, 254)}.{random.randint(1, 254)}"
    environment = {**{k: v for k, v in os.environ.items() if not k.startswith("CAN_")},
                   "XDG_RUNTIME_DIR": str(private_dir.parent), "PYTHONUNBUFFERED": "1"}
    child = subprocess.Popen(
        [sys.executable, "-m", "blinkcan", "emulate", "pkp-3500-mt", "-q", "-i",
         "udp_multicast", "-c", channel, "--bus-kwargs", f"port={random.randint(40000, 60000)}",
         "hop_limit=0"], stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL, env=environment)
    try:
        with command_socket(TypedCommands(live_emulator), Console(file=io.StringIO())):
            deadline = time.monotonic() + 30
            while child.pid not in emulators():
                assert child.poll() is None
                assert time.monotonic() < deadline, "the child's socket did not appear"
                time.sleep(0.05)
            code, _, errors = _act("press", "3")
            assert code == 2
            assert "2 emulators run (" in errors  # in process-id order (pids wrap: either)
            assert f"{os.getpid()}: PKP-2600-SI keypad 15h" in errors
            assert f"{child.pid}: PKP-3500-MT keypad 15h, manual rev 1.3" in errors
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


def test_a_socket_of_a_process_still_alive_is_left_alone(private_dir: Path) -> None:
    """Refused, but its process lives (an emulator between bind and listen): not removed."""
    private_dir.mkdir(mode=0o700)
    starting = private_dir / f"emulate-{os.getpid()}.sock"
    with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as not_yet:
        not_yet.bind(str(starting))
        assert emulators() == {}
        assert starting.exists()
