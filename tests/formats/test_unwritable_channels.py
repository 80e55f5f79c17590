"""A frame's channel that a format cannot hold as written (a name with a space or a newline,
no name at all but a dict or a list, as a udp_multicast datagram may carry) is written on
:data:`~blinkcan.formats.carried.DEFAULT_CHANNEL`, said in a loss line, and never breaks the
file: the frames before and after it are kept, and no text of the name becomes a frame of its
own. A dict channel ended a recording (``unhashable type: 'dict'``); a name with a newline
split a candump line in two, and ``can0 7FF#DEADBEEF\\n(1.0) can0`` wrote a frame never on
the bus."""

from __future__ import annotations

import random
import socket
import time
from pathlib import Path
from typing import Any

import can
import msgpack  # type: ignore[import-untyped]  # python-can's udp_multicast's
import pytest
from click.testing import CliRunner

from blinkcan.cli import convert
from blinkcan.cli.bus_options import cli_bus
from blinkcan.cli.main import cli
from blinkcan.formats.carried import CARRIES, DEFAULT_CHANNEL, channel_key
from blinkcan.formats.log_writers import WRITERS
from blinkcan.formats.logs import FrameWriter, read_messages

WRITE_ONLY = {".txt", ".mf4"}
FORMATS = sorted({*WRITERS, ".pcap"} - WRITE_ONLY)
BAD_CHANNELS = {
    "dict": {"x": 1},
    "list": [1],
    "space and newline": "a b\nc",
    "injected frame": "can0 7FF#DEADBEEF\n(1.0) can0",
    "empty": "",
}


def _frame(ident: int, channel: Any, timestamp: float) -> can.Message:
    return can.Message(arbitration_id=ident, data=[ident & 0xFF], is_extended_id=False,
                       channel=channel, timestamp=timestamp)


@pytest.mark.parametrize("bad", BAD_CHANNELS.values(), ids=list(BAD_CHANNELS))
@pytest.mark.parametrize("suffix", FORMATS)
@pytest.mark.parametrize("live", [True, False], ids=["record", "convert"])
def test_a_channel_the_format_cannot_hold_is_written_on_the_default_and_said(
        tmp_path: Path, suffix: str, bad: object, live: bool) -> None:
    target = tmp_path / f"out{suffix}"
    with FrameWriter(target, live=live) as writer:
        writer.write_message(_frame(0x100, "can1", 1000.0))
        writer.write_message(_frame(0x101, bad, 1000.1))
        writer.write_message(_frame(0x102, "can1", 1000.2))
    assert writer.count == 3
    back = list(read_messages(target))
    assert [m.arbitration_id for m in back] == [0x100, 0x101, 0x102]
    lines = writer.lost_lines()
    assert all("\n" not in line for line in lines), lines
    if CARRIES[suffix].channel != "none":
        assert channel_key(back[1].channel) == DEFAULT_CHANNEL
        assert any(line.startswith("1 frame lost its channel name") and DEFAULT_CHANNEL in line
                   for line in lines), lines
    if suffix == ".log":
        assert target.read_text().count("\n") == 3


@pytest.mark.parametrize("suffix", FORMATS)
def test_record_goes_on_past_a_datagram_with_a_dict_channel(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, suffix: str) -> None:
    group = f"239.74.{random.randint(1, 254)}.{random.randint(1, 254)}"
    port = random.randint(40000, 60000)
    options = ["-i", "udp_multicast", "-c", group, "--bus-kwargs", f"port={port}",
               "hop_limit=0"]
    junk = msgpack.packb({
        "timestamp": time.time(), "arbitration_id": 0x123, "is_extended_id": False,
        "is_remote_frame": False, "is_error_frame": False, "channel": {"x": 1}, "dlc": 1,
        "data": b"\x01", "is_fd": False, "bitrate_switch": False,
        "error_state_indicator": False}, use_bin_type=True)

    def open_then_send() -> can.BusABC:
        bus = cli_bus()
        with can.Bus(interface="udp_multicast", channel=group, port=port,
                     hop_limit=0) as sender, \
                socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as raw:
            raw.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_TTL, 0)
            raw.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_LOOP, 1)
            sender.send(can.Message(arbitration_id=0x70C, data=[0], is_extended_id=False))
            raw.sendto(junk, (group, port))
            sender.send(can.Message(arbitration_id=0x70C, data=[1], is_extended_id=False))
        return bus

    monkeypatch.setattr(convert, "cli_bus", open_then_send)
    target = tmp_path / f"recorded{suffix}"
    result = CliRunner().invoke(cli, ["record", str(target), "--duration", "0.5", *options])
    assert result.exit_code == 0, result.output
    assert "3 frames recorded" in result.stderr, result.stderr
    assert [m.arbitration_id for m in read_messages(target)] == [0x70C, 0x123, 0x70C]
