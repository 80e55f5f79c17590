"""A datagram python-can unpacks into a message that is no frame (an identifier 1.5, a DLC
True, a flag "yes") is a bus error like a datagram it cannot unpack: counted, reported once,
and the recording, the monitor and ``nmt`` go on. Before, one such datagram on the group ended
``record`` (every format) and ``monitor`` with "unexpected ValueError/TypeError", losing the
frames after it."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import can
import msgpack  # type: ignore[import-untyped]  # python-can's udp_multicast's
import pytest
from can.interfaces.udp_multicast.utils import unpack_message
from click.testing import CliRunner

from blinkcan.cli import convert, monitor, nmt
from blinkcan.cli.main import cli
from blinkcan.formats.logs import read_messages

from .test_recording import Script, ScriptedBus, _frame, _numbers

#: maps a udp_multicast peer may send, each unpacked by python-can (ranges checked) into a
#: message that is no frame
HOSTILE: dict[str, dict[str, Any]] = {
    "identifier 1.5": {"arbitration_id": 1.5, "data": b"\x01", "dlc": 1},
    "identifier 5.0": {"arbitration_id": 5.0, "data": b"\x01", "dlc": 1},
    "identifier NaN": {"arbitration_id": math.nan, "data": b"\x01", "dlc": 1},
    "identifier True": {"arbitration_id": True, "data": b"\x01", "dlc": 1},
    "DLC 1.0": {"arbitration_id": 0x123, "data": b"\x01", "dlc": 1.0},
    "DLC True": {"arbitration_id": 0x123, "data": b"\x01", "dlc": True},
    "flag yes": {"arbitration_id": 0x123, "data": b"\x01", "dlc": 1, "is_extended_id": "yes"},
    "error flag no": {"arbitration_id": 0x123, "data": b"\x01", "dlc": 1,
                      "is_error_frame": "no"},
    "FD flag list": {"arbitration_id": 0x123, "data": b"\x01" * 12, "dlc": 12, "is_fd": True,
                     "bitrate_switch": [1]},
}


def _unpacked(fields: dict[str, Any]) -> can.Message:
    """The message python-can's udp_multicast bus returns for this datagram."""
    return unpack_message(msgpack.packb(fields, use_bin_type=True),
                          replace={"timestamp": 1001.5}, check=True)


@pytest.mark.parametrize("name", HOSTILE)
def test_python_can_unpacks_it_and_it_is_no_frame(name: str) -> None:
    from blinkcan.formats.frame_check import wrong_type as not_a_frame
    assert not_a_frame(_unpacked(HOSTILE[name])) is not None


def test_the_frames_python_can_sends_are_frames() -> None:
    from blinkcan.formats.frame_check import wrong_type as not_a_frame
    for message in (_frame(1), can.Message(arbitration_id=0x18EF2100, data=b"\x04\x1b"),
                    can.Message(arbitration_id=0x123, is_remote_frame=True, dlc=8),
                    can.Message(arbitration_id=0x123, data=bytes(64), is_fd=True,
                                bitrate_switch=True, error_state_indicator=True),
                    can.Message(arbitration_id=0x4, is_error_frame=True,
                                data=bytes(8))):
        assert not_a_frame(_unpacked({k: getattr(message, k) for k in (
            "arbitration_id", "is_extended_id", "is_remote_frame", "is_error_frame",
            "dlc", "data", "is_fd", "bitrate_switch", "error_state_indicator")})) is None


@pytest.mark.parametrize("suffix", [".log", ".pcap", ".blf", ".asc", ".trc", ".csv"])
@pytest.mark.parametrize("name", HOSTILE)
def test_one_such_datagram_never_ends_a_recording(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, name: str, suffix: str) -> None:
    script: Script = [_frame(0), _frame(1), _unpacked(HOSTILE[name]), _frame(2), _frame(3)]
    monkeypatch.setattr(convert, "cli_bus", lambda: ScriptedBus(script))
    target = tmp_path / f"live{suffix}"
    result = CliRunner().invoke(cli, ["record", str(target)])
    assert result.exit_code == 0, result.output
    assert _numbers(target) == [0, 1, 2, 3]
    assert len(list(read_messages(target))) == 4  # nothing of the datagram in the file
    assert result.output.count("bus error: received a message that is no CAN frame") == 1
    assert "1 bus error while reading" in result.output
    assert "4 frames recorded" in result.output


def test_the_monitor_goes_on_after_one(monkeypatch: pytest.MonkeyPatch) -> None:
    heartbeat = can.Message(timestamp=1002.0, arbitration_id=0x715, data=b"\x05",
                            is_extended_id=False)
    script: Script = [_unpacked(HOSTILE["identifier 1.5"]), heartbeat]
    monkeypatch.setattr(monitor, "cli_bus", lambda: ScriptedBus(script, quiet=True))
    result = CliRunner().invoke(cli, ["monitor", "--duration", "2"])
    assert result.exit_code == 0, result.output
    assert result.output.count("bus error: received a message that is no CAN frame: "
                               "identifier 1.5 is not an integer") == 1
    assert "715" in result.output


class _SendingBus(ScriptedBus):
    def send(self, msg: can.Message, timeout: float | None = None) -> None:
        pass


def test_nmt_hears_the_heartbeat_after_one(monkeypatch: pytest.MonkeyPatch) -> None:
    float_heartbeat = _unpacked({"arbitration_id": 1804.0, "data": b"\x05", "dlc": 1,
                                 "is_extended_id": False})
    script: Script = [None, float_heartbeat,
                      can.Message(timestamp=2e9, arbitration_id=0x70C, data=b"\x05",
                                  is_extended_id=False)]
    monkeypatch.setattr(nmt, "cli_bus", lambda: _SendingBus(script, quiet=True))
    result = CliRunner().invoke(cli, ["nmt", "start", "0x0C", "--listen", "1"])
    assert result.exit_code == 0, result.output
    assert "node 0Ch: operational" in result.output
