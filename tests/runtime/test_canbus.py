from __future__ import annotations

import pytest

from blinkcan.protocol import Frame
from blinkcan.runtime import open_bus, to_frame, to_message


def test_python_can_configuration_is_honoured(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("CAN_INTERFACE", "virtual")
    monkeypatch.setenv("CAN_CHANNEL", "from-environment")
    bus = open_bus()
    try:
        assert "from-environment" in bus.channel_info
    finally:
        bus.shutdown()


def test_without_configuration_the_bus_is_virtual(monkeypatch: pytest.MonkeyPatch,
                                                   tmp_path: object) -> None:
    for name in ("CAN_INTERFACE", "CAN_CHANNEL", "CAN_BITRATE", "CAN_CONFIG"):
        monkeypatch.delenv(name, raising=False)
    monkeypatch.setenv("HOME", str(tmp_path))
    monkeypatch.chdir(str(tmp_path))
    bus = open_bus()
    try:
        assert "blinkcan" in bus.channel_info
    finally:
        bus.shutdown()


def test_frames_round_trip_through_messages() -> None:
    for frame in (Frame(0x615, b"\x40\x00\x10\x00"), Frame(0x18EF2100, bytes(8), True)):
        assert to_frame(to_message(frame)) == frame
