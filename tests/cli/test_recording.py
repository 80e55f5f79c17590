"""A recorder keeps everything it recorded whatever ends it: a bus error is counted and the
recording goes on, a bus that keeps failing ends it with the file kept (issue 18 item 1); the
capture is under its own name as it is written, so a killed recorder leaves it there, valid up
to its last flush (item 2)."""

from __future__ import annotations

import itertools
import json
import os
import random
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import can
import pytest
from click.testing import CliRunner

from blinkcan.cli import convert, monitor
from blinkcan.cli.bus_faults import BusFaults
from blinkcan.cli.main import cli
from blinkcan.formats.logs import read_messages

JUNK = can.CanOperationError("could not unpack received message")
Script = Iterable[can.Message | BaseException | None]


class ScriptedBus:
    """A bus whose ``recv`` returns (or raises) the script's items, then Ctrl-C (or, with
    ``quiet``, nothing, as a quiet bus)."""

    def __init__(self, script: Iterable[can.Message | BaseException | None],
                 quiet: bool = False) -> None:
        self._script = iter(script)
        self._quiet = quiet

    def recv(self, timeout: float | None = None) -> can.Message | None:
        item = next(self._script, None if self._quiet else KeyboardInterrupt())
        if item is None:
            time.sleep(timeout or 0.0)
        elif isinstance(item, BaseException):
            raise item
        return item

    def shutdown(self) -> None:
        pass


def _frame(number: int) -> can.Message:
    return can.Message(timestamp=1000.0 + number, arbitration_id=0x715,
                       data=number.to_bytes(2, "big"), is_extended_id=False)


def _numbers(path: Path) -> list[int]:
    return [int.from_bytes(m.data, "big") for m in read_messages(path)
            if m.arbitration_id == 0x715]


@pytest.mark.parametrize("suffix", [".pcap", ".log"])
def test_a_bus_error_is_counted_reported_once_and_the_recording_goes_on(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, suffix: str) -> None:
    script: Script = [_frame(0), _frame(1), JUNK, _frame(2), JUNK, JUNK, None, _frame(3)]
    monkeypatch.setattr(convert, "cli_bus", lambda: ScriptedBus(script))
    target = tmp_path / f"live{suffix}"
    result = CliRunner().invoke(cli, ["record", str(target)])
    assert result.exit_code == 0, result.output
    assert _numbers(target) == [0, 1, 2, 3]
    assert result.output.count("bus error: could not unpack received message") == 1
    assert "3 bus errors while reading (first: could not unpack received message)" in \
        result.output
    assert "4 frames recorded" in result.output


def test_a_bus_that_keeps_failing_ends_the_recording_and_keeps_the_file(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(BusFaults, "give_up_after", 0.05)
    failing = can.CanOperationError("failed to receive")
    script: Script = itertools.chain([_frame(0), _frame(1), JUNK, _frame(2)],
                                     itertools.repeat(failing))
    monkeypatch.setattr(convert, "cli_bus", lambda: ScriptedBus(script))
    target = tmp_path / "live.pcap"
    result = CliRunner().invoke(cli, ["record", str(target)])
    assert result.exit_code == 1
    assert "the bus kept failing for 0.05 s" in result.output
    assert f"the 3 frames recorded until then are in {target}" in result.output
    assert _numbers(target) == [0, 1, 2]


def test_whatever_ends_a_recording_keeps_what_it_recorded(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    script: Script = [_frame(0), _frame(1), RuntimeError("a driver bug")]
    monkeypatch.setattr(convert, "cli_bus", lambda: ScriptedBus(script))
    target = tmp_path / "live.log"
    result = CliRunner().invoke(cli, ["record", str(target)])
    assert result.exit_code == 1
    assert "a driver bug" in result.output
    assert _numbers(target) == [0, 1]


def test_monitor_counts_bus_errors_and_goes_on(monkeypatch: pytest.MonkeyPatch) -> None:
    heartbeat = can.Message(timestamp=1.0, arbitration_id=0x715, data=b"\x05",
                            is_extended_id=False)
    script: Script = [JUNK, heartbeat, JUNK]
    monkeypatch.setattr(monitor, "cli_bus", lambda: ScriptedBus(script, quiet=True))
    result = CliRunner().invoke(cli, ["monitor", "--duration", "2"])  # ample on a loaded machine
    assert result.exit_code == 0, result.output
    assert result.output.count("bus error: could not unpack received message") == 1
    assert "2 bus errors while reading" in result.output
    assert "715" in result.output  # the heartbeat after the first error was shown


@pytest.mark.multiprocess
def test_a_datagram_that_is_not_a_frame_does_not_end_a_real_recording(tmp_path: Path) -> None:
    """The issue's case: ``record x.pcap`` on udp_multicast, 100 frames, then one datagram that
    python-can cannot unpack, then more frames; SIGTERM ends it with every frame kept."""
    channel = f"239.74.{random.randint(1, 254)}.{random.randint(1, 254)}"
    port = random.randint(40000, 60000)
    config: dict[str, Any] = {"port": port, "hop_limit": 0}
    try:
        host = can.Bus(interface="udp_multicast", channel=channel, receive_own_messages=False,
                       **config)
    except (OSError, ImportError, can.CanError) as error:
        pytest.skip(f"udp_multicast unavailable here ({error})")
    junk = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    junk.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_TTL, 0)
    target = tmp_path / "x.pcap"
    child = subprocess.Popen(
        [sys.executable, "-m", "blinkcan", "record", str(target), "-i", "udp_multicast",
         "-c", channel], stderr=subprocess.PIPE, text=True,
        env={**os.environ, "PYTHONUNBUFFERED": "1", "CAN_CONFIG": json.dumps(config)})
    try:
        assert child.stderr is not None
        assert "recording" in child.stderr.readline()
        deadline = time.monotonic() + 15
        while time.monotonic() < deadline:  # until the recorder hears us (it may start late)
            host.send(can.Message(arbitration_id=0x70C, data=b"\x7f", is_extended_id=False))
            time.sleep(0.2)
            if any(p.stat().st_size > 24 for p in tmp_path.iterdir()):
                break
        for number in range(100):
            host.send(_frame(number))
        junk.sendto(b"\xc1 not a python-can frame", (channel, port))
        time.sleep(0.2)
        for number in range(100, 105):
            host.send(_frame(number))
        time.sleep(1.5)  # the recorder flushes at least every second
        child.send_signal(signal.SIGTERM)
        _, errors = child.communicate(timeout=10)
    finally:
        if child.poll() is None:
            child.kill()
        host.shutdown()
        junk.close()
    assert child.returncode == 0, errors
    assert errors.count("bus error: could not unpack received message") == 1, errors
    assert "1 bus error while reading" in errors
    assert _numbers(target) == list(range(105))


def _holds(target: Path, numbers: list[int]) -> bool:
    """Whether ``target``, read by this process while its recorder writes it, holds
    ``numbers`` (a file in the middle of a flush may not read yet)."""
    try:
        return _numbers(target) == numbers
    except Exception:
        return False


@pytest.mark.multiprocess
def test_a_killed_recorder_leaves_its_capture_under_its_own_name(tmp_path: Path) -> None:
    """SIGKILL (as the OOM killer sends) during ``record``: each file is under the name asked
    for, nothing hidden beside it, and holds every frame sent before the recorder's last flush
    (at least every second).

    The kill comes once every file shows the frames to another process (each recorder
    flushed them), not after a fixed wait: a recorder the machine's load kept from running
    for a second or two had not flushed yet (its frames missing), or was in the middle of its
    SQLite commit (a hot ``killed.db-journal`` beside the file), and the test failed."""
    channel = f"239.74.{random.randint(1, 254)}.{random.randint(1, 254)}"
    port = random.randint(40000, 60000)
    config: dict[str, Any] = {"port": port, "hop_limit": 0}
    try:
        host = can.Bus(interface="udp_multicast", channel=channel, receive_own_messages=False,
                       **config)
    except (OSError, ImportError, can.CanError) as error:
        pytest.skip(f"udp_multicast unavailable here ({error})")
    # one of each way a format is written: binary stream, text (.asc: without its footer),
    # BLF's compressed containers and header, python-can's SQLite writer thread
    targets = [tmp_path / f"killed{suffix}" for suffix in (".pcap", ".log", ".asc", ".blf",
                                                            ".db")]
    children = [subprocess.Popen(
        [sys.executable, "-m", "blinkcan", "record", str(target), "-i", "udp_multicast",
         "-c", channel], stderr=subprocess.PIPE, text=True,
        env={**os.environ, "PYTHONUNBUFFERED": "1", "CAN_CONFIG": json.dumps(config)})
        for target in targets]
    try:
        for child in children:  # each has joined the group when it says so
            assert child.stderr is not None
            assert "recording" in child.stderr.readline()
        for number in range(50):
            host.send(_frame(number))
        deadline = time.monotonic() + 60  # only so that a recorder that never flushes fails
        while not all(_holds(target, list(range(50))) for target in targets):
            assert time.monotonic() < deadline, "a recorder did not flush its frames in 60 s"
            time.sleep(0.1)
        for child in children:
            child.kill()
            child.wait(timeout=10)
    finally:
        for child in children:
            if child.poll() is None:
                child.kill()
            if child.stderr is not None:
                child.stderr.close()
        host.shutdown()
    assert all(child.returncode == -signal.SIGKILL for child in children)
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(t.name for t in targets)
    for target in targets:
        assert _numbers(target) == list(range(50)), target.name


def test_a_recording_never_follows_a_symlink_planted_at_its_name(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    victim = tmp_path / "victim"
    target = tmp_path / "x.pcap"
    target.symlink_to(victim)  # dangling: the recording would create the victim through it
    monkeypatch.setattr(convert, "cli_bus", lambda: ScriptedBus([_frame(0)]))
    refused = CliRunner().invoke(cli, ["record", str(target)])
    assert refused.exit_code == 1
    assert "exists; pass --force" in refused.output
    assert not victim.exists()
    forced = CliRunner().invoke(cli, ["record", str(target), "--force"])
    assert forced.exit_code == 0, forced.output
    assert not victim.exists()
    assert not target.is_symlink()
    assert _numbers(target) == [0]


def test_a_recording_that_cannot_survive_a_kill_is_refused(tmp_path: Path) -> None:
    result = CliRunner().invoke(cli, ["record", str(tmp_path / "x.mf4")])
    assert result.exit_code == 1
    assert "cannot record to x.mf4: .mf4 is written only when it is closed" in result.output
    assert list(tmp_path.iterdir()) == []
