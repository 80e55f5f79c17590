"""Lossless captures: remote and error frames kept through convert, record and pcap; what a
format cannot carry counted and named; partial files safe; bad files one line; bounded reads."""

from __future__ import annotations

import importlib.util
import io
import json
import os
import random
import shutil
import signal
import struct
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import can
import pytest
from click.testing import CliRunner

from blinkcan.cli.main import cli
from blinkcan.formats.logs import FrameWriter, LogError, frame_kind, read_messages
from blinkcan.formats.pcap import PcapError, read_pcap_messages

LOG = """\
(1000.000000) can0 715#05
(1000.010000) can0 70C#R
(1000.020000) can0 20000080#0000000000000000
(1000.030000) can0 18C#0800000000000000
"""

PCAP_HEADER = struct.pack("<IHHiIII", 0xA1B2C3D4, 2, 4, 0, 0, 65535, 227)


def _packet(can_id: int, data: bytes, seconds: int = 1) -> bytes:
    record = struct.pack(">IB3x8s", can_id, len(data), data.ljust(8, b"\x00"))
    return struct.pack("<IIII", seconds, 0, len(record), len(record)) + record


@pytest.fixture
def candump(tmp_path: Path) -> Path:
    path = tmp_path / "guarding.log"
    path.write_text(LOG)
    return path


def _kinds(path: Path) -> list[tuple[str, int]]:
    return [(frame_kind(m), m.arbitration_id) for m in read_messages(path)]


@pytest.mark.parametrize("suffix", [".pcap", ".asc", ".log", ".blf", ".csv", ".db"])
def test_convert_keeps_remote_and_error_frames(candump: Path, tmp_path: Path,
                                               suffix: str) -> None:
    target = tmp_path / f"out{suffix}"
    result = CliRunner().invoke(cli, ["convert", str(candump), str(target)])
    assert result.exit_code == 0, result.output
    assert "4 frames written" in result.output
    kinds = _kinds(target)
    assert [k for k, _ in kinds] == ["data", "remote", "error", "data"]
    assert kinds[1] == ("remote", 0x70C)


def test_a_pcap_carries_the_error_class_and_reads_back_as_an_error_frame(tmp_path: Path
                                                                         ) -> None:
    path = tmp_path / "errors.pcap"
    path.write_bytes(PCAP_HEADER + _packet(0x20000004, bytes(8)) + _packet(0x70C | 0x40000000,
                                                                          b""))
    messages = list(read_messages(path))
    assert messages[0].is_error_frame
    assert messages[0].arbitration_id == 0x004
    assert messages[1].is_remote_frame
    assert messages[1].arbitration_id == 0x70C
    decoded = CliRunner().invoke(cli, ["decode", str(path)])
    assert decoded.exit_code == 0, decoded.output
    lines = decoded.stdout.splitlines()
    assert "error frame: controller problem" in lines[0]
    assert "keybox 0Ch: node guarding request" in lines[1]
    as_json = CliRunner().invoke(cli, ["decode", "--json", str(path)])
    assert [json.loads(line)["kind"] for line in as_json.stdout.splitlines()] == [
        "error", "remote"]


def test_a_format_that_cannot_carry_a_frame_refuses_it_naming_how_many(candump: Path,
                                                                        tmp_path: Path) -> None:
    # TRC has remote frames (RR) and python-can reads them; it has no error frame python-can
    # reads: the conversion is refused, nothing written (it dropped both and exited 0)
    target = tmp_path / "out.trc"
    result = CliRunner().invoke(cli, ["convert", str(candump), str(target)])
    assert result.exit_code == 1, result.output
    assert result.output == (f"Error: {candump} holds 1 frame .trc cannot carry (1 error: "
                             f"error frame): nothing written to {target}; these formats hold "
                             "them: .asc .blf .cap .csv .db .log .mf4 .pcap\n")
    assert not list(tmp_path.glob("*.trc"))
    without_error = tmp_path / "remote.log"
    without_error.write_text("".join(line + "\n" for line in LOG.splitlines()
                                     if "20000080#" not in line))
    result = CliRunner().invoke(cli, ["convert", str(without_error), str(target)])
    assert result.exit_code == 0, result.output
    assert _kinds(target) == _kinds(without_error)


def test_the_partial_file_is_unpredictable_and_never_follows_a_planted_symlink(
        candump: Path, tmp_path: Path) -> None:
    victim = tmp_path / "victim.txt"
    victim.write_text("precious")
    for name in (".out.partial.asc", ".out.partial.pcap"):
        (tmp_path / name).symlink_to(victim)
    for suffix in (".asc", ".pcap"):
        result = CliRunner().invoke(cli, ["convert", str(candump), str(tmp_path / f"out{suffix}")])
        assert result.exit_code == 0, result.output
    assert victim.read_text() == "precious"
    first, second = FrameWriter(tmp_path / "a.pcap"), FrameWriter(tmp_path / "b.pcap")
    try:
        names = [p.name for p in tmp_path.iterdir() if p.name.startswith((".a.", ".b."))]
        assert len(names) == 2
        assert all(len(name) > len(".a.pcap") + 6 for name in names)  # a random part
    finally:
        first.close()
        second.close()


def test_pcap_is_streamed_to_disk_as_frames_come(tmp_path: Path) -> None:
    writer = FrameWriter(tmp_path / "live.pcap")
    for n in range(3):
        writer.write_message(can.Message(timestamp=n, arbitration_id=0x715, data=b"\x05",
                                         is_extended_id=False))
    writer.flush()
    partial = [p for p in tmp_path.iterdir() if p.name.startswith(".live.pcap")]
    assert [p.stat().st_size for p in partial] == [24 + 3 * 32]
    writer.close()
    assert (tmp_path / "live.pcap").stat().st_size == 24 + 3 * 32


class _Recording(io.BytesIO):
    """A stream that remembers the largest read asked of it."""

    largest = 0

    def read(self, size: int | None = -1) -> bytes:
        self.largest = max(self.largest, size if size is not None else -1)
        return super().read(size)


def test_a_pcap_record_length_is_never_trusted() -> None:
    claim = 2**31  # a 2 GB packet, as a sparse file would say
    stream = _Recording(PCAP_HEADER + struct.pack("<IIII", 1, 0, claim, claim) + bytes(64))
    with pytest.raises(PcapError, match="packet 1: 2147483648 bytes, not a SocketCAN frame"):
        list(read_pcap_messages(stream))
    assert stream.largest <= 72


@pytest.mark.parametrize(("packet", "message"), [
    (_packet(0x0000800, b"\x01"), "standard identifier 800h is over 7FFh"),
    (_packet(0x00000715, b"\x01")[:20], "truncated"),
])
def test_bad_pcaps_are_one_line(packet: bytes, message: str, tmp_path: Path) -> None:
    path = tmp_path / "bad.pcap"
    path.write_bytes(PCAP_HEADER + packet)
    for args in (["decode", str(path)], ["convert", str(path), str(tmp_path / "out.asc")]):
        result = CliRunner().invoke(cli, args)
        assert result.exit_code == 1
        assert message in result.output
        assert "Traceback" not in result.output
    assert not (tmp_path / "out.asc").exists()


@pytest.mark.parametrize(("suffix", "message"), [
    (".blf", "not a readable log"), (".db", "not a readable log"),
])
def test_garbage_logs_are_one_line(suffix: str, message: str, tmp_path: Path) -> None:
    path = tmp_path / f"garbage{suffix}"
    path.write_bytes(random.Random(1).randbytes(3000))
    for args in (["decode", str(path)], ["convert", str(path), str(tmp_path / "out.log")]):
        result = CliRunner().invoke(cli, args)
        assert result.exit_code == 1, result.output
        assert message in result.output
        assert result.exception is None or isinstance(result.exception, SystemExit)


def test_mf4_without_asammdf_is_one_line(tmp_path: Path, candump: Path) -> None:
    if importlib.util.find_spec("asammdf") is not None:
        pytest.skip("asammdf is installed here")
    path = tmp_path / "capture.mf4"
    path.write_bytes(b"MDF     4.10    ")
    for args in (["decode", str(path)], ["convert", str(candump), str(path.with_name("o.mf4"))]):
        result = CliRunner().invoke(cli, args)
        assert result.exit_code == 1, result.output
        assert "MF4 needs asammdf" in result.output
        assert result.exception is None or isinstance(result.exception, SystemExit)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["capture.mf4", "guarding.log"]


def test_read_messages_of_a_missing_file_is_a_log_error(tmp_path: Path) -> None:
    with pytest.raises(LogError, match="no such file"):
        list(read_messages(tmp_path / "missing.log"))


@pytest.mark.multiprocess
@pytest.mark.parametrize("suffix", [".pcap", ".log"])
def test_record_stops_cleanly_on_sigterm_keeping_every_frame(tmp_path: Path,
                                                              suffix: str) -> None:
    channel = f"239.74.{random.randint(1, 254)}.{random.randint(1, 254)}"
    port = random.randint(40000, 60000)
    config: dict[str, Any] = {"port": port, "hop_limit": 0}
    try:
        host = can.Bus(interface="udp_multicast", channel=channel, receive_own_messages=False,
                       **config)
    except (OSError, ImportError, can.CanError) as error:
        pytest.skip(f"udp_multicast unavailable here ({error})")
    target = tmp_path / f"live{suffix}"
    child = subprocess.Popen(
        [sys.executable, "-m", "blinkcan", "record", str(target), "-i", "udp_multicast",
         "-c", channel], stderr=subprocess.PIPE, text=True,
        env={**os.environ, "PYTHONUNBUFFERED": "1", "CAN_CONFIG": json.dumps(config)})
    try:
        assert child.stderr is not None
        assert "recording" in child.stderr.readline()
        sent = [can.Message(arbitration_id=0x715, data=b"\x05", is_extended_id=False),
                can.Message(arbitration_id=0x70C, is_remote_frame=True, is_extended_id=False),
                can.Message(arbitration_id=0x18C, data=bytes(8), is_extended_id=False)]
        deadline = time.monotonic() + 10
        while time.monotonic() < deadline:  # until the recorder hears us (it may start late)
            for message in sent:
                host.send(message)
            time.sleep(0.3)
            if (target.exists() and target.stat().st_size > 200) or suffix == ".log":
                break
        time.sleep(0.3)
        child.send_signal(signal.SIGTERM)
        _, errors = child.communicate(timeout=10)
    finally:
        if child.poll() is None:
            child.kill()
        host.shutdown()
    assert child.returncode == 0, errors
    assert "frames recorded" in errors
    assert sorted(p.name for p in tmp_path.iterdir()) == [target.name]  # nothing beside it
    kinds = [(frame_kind(m), m.arbitration_id) for m in read_messages(target)]
    assert ("remote", 0x70C) in kinds
    assert ("data", 0x715) in kinds


def test_can_fd_frames_go_through_a_pcap_whole(tmp_path: Path) -> None:
    source = tmp_path / "fd.log"
    source.write_text("(1.0) can0 123##1" + bytes(range(12)).hex().upper() + "\n"
                      "(2.0) can0 715#05\n")
    target = tmp_path / "fd.pcap"
    result = CliRunner().invoke(cli, ["convert", str(source), str(target)])
    assert result.exit_code == 0, result.output
    messages = list(read_messages(target))
    assert messages[0].is_fd
    assert bytes(messages[0].data) == bytes(range(12))
    assert bytes(messages[1].data) == b"\x05"


def test_an_error_frames_class_and_data_survive_a_candump_log(tmp_path: Path) -> None:
    source = tmp_path / "errors.log"
    source.write_text("(1.0) can0 715#05\n\n(2.0) can0 20000044#0000000000000000\n")
    target = tmp_path / "errors.pcap"
    assert CliRunner().invoke(cli, ["convert", str(source), str(target)]).exit_code == 0
    error = list(read_messages(target))[1]
    assert error.is_error_frame
    assert error.arbitration_id == 0x44  # python-can's reader alone keeps 0 and no data
    assert bytes(error.data) == bytes(8)
    decoded = CliRunner().invoke(cli, ["decode", str(source)])
    assert "error frame: controller problem, bus-off" in decoded.stdout


def test_wireshark_reads_remote_error_and_fd_frames_of_our_pcap(candump: Path,
                                                                 tmp_path: Path) -> None:
    tshark = shutil.which("tshark")
    if tshark is None:
        pytest.skip("tshark is not installed (apt-get install tshark to run this check)")
    with candump.open("a") as stream:
        stream.write("(1000.040000) can0 123##1" + bytes(range(12)).hex() + "\n")
    target = tmp_path / "all.pcap"
    assert CliRunner().invoke(cli, ["convert", str(candump), str(target)]).exit_code == 0
    result = subprocess.run([tshark, "-r", str(target), "-V"], capture_output=True, text=True,
                            timeout=60, check=True)
    assert "Remote Transmission Request Flag: True" in result.stdout
    assert "Error Message Flag: True" in result.stdout
    assert "Bus error: True" in result.stdout
    assert "Controller Area Network FD, ID: 291 (0x123), Length: 12" in result.stdout
