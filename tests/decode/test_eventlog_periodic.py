"""Periodic frames fold like heartbeats in the events a person watches (issue 20 item 15): which
frames are periodic comes from the model's description (a TPDO's transmission period)."""

from __future__ import annotations

import uuid
from typing import Any

import can
import pytest

from blinkcan.decode import Decoder
from blinkcan.decode.eventlog import EventLog
from blinkcan.devices.registry import models
from blinkcan.protocol import Frame
from blinkcan.runtime import Emulator, to_message
from blinkcan.twin import KeypadTwin
from blinkcan.twin.registry import build_twin
from tests.host.conftest import wait_until


def _periodic_models() -> list[str]:
    return [m.name for m in models() if any(p.period for p in m.description().tx_pdos)]


@pytest.mark.parametrize("model", [m.name for m in models()])
def test_a_periodic_pdo_names_the_entry_that_sets_its_period(model: str) -> None:
    description = build_twin(model).description
    for layout in description.tx_pdos:
        if layout.period:
            entry = description.table[layout.period]
            assert entry.unit in ("ms", "10 ms"), (layout.name, entry)


def test_the_pkp3500_analog_frames_fold_and_a_change_is_a_row_of_its_own() -> None:
    assert "pkp-3500-mt" in _periodic_models()
    twin: Any = KeypadTwin(node_id=0x15, model="pkp-3500-mt")  # + set_analog
    decoder = Decoder({0x15: twin.description})
    log = EventLog(5, decoder)
    frames = [(0.0, f) for f in twin.power_on(0.0)]
    frames += [(0.0, f) for f in twin.receive(Frame(0, b"\x01\x15"), 0.0)]  # NMT start
    frames += [(0.05, f) for f in twin.press(4, 0.05)]
    now = 0.0
    while now < 2.0:  # 80 ms analog frames (MT §14) for two seconds
        now += 0.01
        frames += [(now, f) for f in twin.advance(now)]
    frames += [(2.0, f) for f in twin.set_analog(1, 2.5, 2.0)]
    for t in (2.5, 3.0):
        frames += [(t, f) for f in twin.advance(t)]
    for t, item in frames:
        log.add(decoder.decode(item, t))
    texts = [row.text() for row in log.rows]
    assert any("key 4 pressed" in text for text in texts)  # not pushed off by 25 frames
    analog = [row for row in log.rows if row.event.fields.get("pdo") == "analog_inputs"]
    assert len(analog) == 2, texts  # before and after the change, each folded
    assert analog[0].count >= 20
    assert analog[1].count > 1
    assert analog[0].event.text != analog[1].event.text


def test_an_event_driven_pdo_never_folds() -> None:
    decoder = Decoder({0x15: "keypad"})
    log = EventLog(5, decoder)
    for n in range(3):  # LEDs on, twice the same: two commands, two rows
        log.add(decoder.decode(Frame(0x215, bytes(8)), float(n)))
    assert [row.count for row in log.rows] == [1, 1, 1]


def test_the_panel_folds_the_pkp3500_analog_frames() -> None:
    pytest.importorskip("starlette", reason="the web extra is not installed")
    from blinkcan.web.app import FRAMES_KEPT, Panel

    channel = f"panel-periodic-{uuid.uuid4().hex}"
    device_bus, host = (can.Bus(interface="virtual", channel=channel) for _ in range(2))
    try:
        twin = KeypadTwin(node_id=0x15, model="pkp-3500-mt")
        with Emulator(device_bus, [twin]) as emulator:
            panel = Panel(emulator)
            host.send(to_message(Frame(0, b"\x01\x15")))  # operational: 495h every 80 ms
            wait_until(lambda: any(f["id"] == "495" and "(x3)" in f["text"]
                                   for f in panel.frames), timeout=10)
            frames = panel.frames
    finally:
        device_bus.shutdown()
        host.shutdown()
    analog = [f for f in frames if f["id"] == "495"]
    assert len(analog) == 1, frames
    assert len(frames) < FRAMES_KEPT
