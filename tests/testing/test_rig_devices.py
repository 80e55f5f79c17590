"""Every Rig fault and input call takes the twin or the node id it answers at, and refuses
anything else with a TypeError (issue 17 item 12: ``rig.drop_node(keybox_twin)`` was accepted and
dropped nothing)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import pytest

from blinkcan.testing import Rig
from blinkcan.twin import KeyboxTwin, KeypadTwin

KEYBOX = 0x0C
KEYPAD = 0x15


def rig_with_twins() -> tuple[Rig, KeypadTwin, KeyboxTwin]:
    rig = Rig()
    keypad = rig.add(KeypadTwin(KEYPAD, settings={"startup_led_show": 0,
                                                  "producer_heartbeat_time": 100}))
    keybox = rig.add(KeyboxTwin(KEYBOX, settings={"producer_heartbeat_time": 100}))
    rig.advance(0.05)  # boot-up frames sent
    return rig, keypad, keybox


def frames_of_node(rig: Rig, start: float, node_id: int) -> list[int]:
    return [timed.frame.can_id for timed in rig.frames_since(start)
            if not timed.frame.extended and timed.frame.can_id > 0x80
            and timed.frame.can_id & 0x7F == node_id]


@pytest.mark.parametrize("by", ["twin", "node id"])
def test_drop_node_drops_the_device_named_by_its_twin_or_its_node_id(by: str) -> None:
    rig, _, keybox = rig_with_twins()
    with rig:
        undo = rig.drop_node(keybox if by == "twin" else KEYBOX)
        start = rig.now
        rig.advance(1.0)
        assert frames_of_node(rig, start, KEYBOX) == []
        assert frames_of_node(rig, start, KEYPAD)  # only that device
        undo()
        start = rig.now
        rig.advance(1.0)
        assert 0x700 + KEYBOX in frames_of_node(rig, start, KEYBOX)


@pytest.mark.parametrize("by", ["twin", "node id"])
def test_stop_heartbeat_takes_the_twin_or_its_node_id(by: str) -> None:
    rig, _, keybox = rig_with_twins()
    with rig:
        undo = rig.stop_heartbeat(keybox if by == "twin" else KEYBOX)
        start = rig.now
        rig.advance(1.0)
        assert 0x700 + KEYBOX not in frames_of_node(rig, start, KEYBOX)
        undo()


def test_inputs_and_faults_take_a_node_id() -> None:
    rig, keypad, keybox = rig_with_twins()
    with rig:
        rig.power_cycle(KEYPAD)
        rig.blow_fuse(KEYBOX, 3)
        assert keybox.snapshot()["pins"][2]["fuse"] == "blown"
        rig.replace_fuse(KEYBOX, 3)
        rig.set_input(KEYBOX, 5, True)
        rig.press(KEYPAD, 4)
        assert keypad.keys_pressed == {4}
        rig.release(KEYPAD, 4)
        rig.tap(KEYPAD, 2)
        assert rig.snapshot(KEYBOX)["pins"][2]["fuse"] == "ok"
        rig.power_off(KEYBOX)
        assert not keybox.powered
        rig.power_on(KEYBOX)
        assert keybox.powered


def _calls() -> dict[str, Callable[[Rig, Any], object]]:
    """Every Rig call that names a device, with that device as its argument."""
    return {
        "power_off": lambda rig, d: rig.power_off(d),
        "power_on": lambda rig, d: rig.power_on(d),
        "power_cycle": lambda rig, d: rig.power_cycle(d),
        "press": lambda rig, d: rig.press(d, 1),
        "release": lambda rig, d: rig.release(d, 1),
        "tap": lambda rig, d: rig.tap(d, 1),
        "long_press": lambda rig, d: rig.long_press(d, 1),
        "turn": lambda rig, d: rig.turn(d, 1, 1),
        "set_analog": lambda rig, d: rig.set_analog(d, 0, 1.0),
        "set_digital_input": lambda rig, d: rig.set_digital_input(d, 0, True),
        "blow_fuse": lambda rig, d: rig.blow_fuse(d, 1),
        "replace_fuse": lambda rig, d: rig.replace_fuse(d, 1),
        "set_input": lambda rig, d: rig.set_input(d, 1, True),
        "drop_node": lambda rig, d: rig.drop_node(d),
        "stop_heartbeat": lambda rig, d: rig.stop_heartbeat(d),
        "snapshot": lambda rig, d: rig.snapshot(d),
    }


@pytest.mark.parametrize("device", ["0x0C", None, 12.0, True, object(), [KEYBOX]],
                         ids=["str", "None", "float", "bool", "object", "list"])
@pytest.mark.parametrize("call", list(_calls()))
def test_anything_but_a_twin_or_a_node_id_is_a_type_error(call: str, device: object) -> None:
    rig, _, _ = rig_with_twins()
    with rig:
        before = len(rig.frames)
        with pytest.raises(TypeError, match="twin or a node id"):
            _calls()[call](rig, device)
        rig.advance(0.0)
        assert len(rig.frames) == before


@pytest.mark.parametrize("call", list(_calls()))
def test_a_node_id_no_twin_answers_at_and_a_twin_not_on_the_rig_are_refused(call: str) -> None:
    rig, _, _ = rig_with_twins()
    with rig:
        if call not in ("drop_node", "stop_heartbeat"):  # these take any device's node id
            with pytest.raises(ValueError, match="no twins answer at node 33h"):
                _calls()[call](rig, 0x33)
        with pytest.raises(ValueError, match="not on the rig"):
            _calls()[call](rig, KeyboxTwin(0x22))
        with pytest.raises(ValueError, match="node id"):
            _calls()[call](rig, 0x80)


@pytest.mark.parametrize(("call", "device"), [("press", KEYBOX), ("turn", KEYPAD),
                                              ("blow_fuse", KEYPAD), ("set_analog", KEYBOX)])
def test_an_input_the_device_does_not_have_is_a_type_error(call: str, device: int) -> None:
    rig, _, _ = rig_with_twins()
    with rig, pytest.raises(TypeError, match="has no"):
        _calls()[call](rig, device)
