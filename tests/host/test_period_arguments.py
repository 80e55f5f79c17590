"""Every driver call that takes a period in seconds checks it as a time (DESIGN: non-finite
times are ValueError, a non-number is TypeError, both naming what is wrong) before anything is
sent: ``monitor_heartbeat(inf)`` was an OverflowError, ``(nan)`` "cannot convert float NaN to
integer", ``(True)`` a heartbeat of 1 s and ``("3")`` "type str doesn't define __round__"
(found by the attack pass of session 5)."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import Any

import pytest

from blinkcan import Keybox, Keypad
from blinkcan.testing import Rig
from blinkcan.twin import KeyboxTwin, KeypadTwin

BAD = [(float("nan"), ValueError), (float("inf"), ValueError), (float("-inf"), ValueError),
       (True, TypeError), ("3", TypeError), (None, TypeError),
       (1e308, ValueError)]  # finite, yet no count of ms holds it: was an OverflowError


@pytest.fixture
def drivers() -> Iterator[dict[str, Any]]:
    rig = Rig()
    rig.add(KeypadTwin(node_id=0x15, manual="1.5", settings={"startup_led_show": 0}))
    rig.add(KeyboxTwin(node_id=0x0C))
    rig.add(KeypadTwin(node_id=0x16, model="pkp-3500-mt"))
    yield {"rig": rig, "keypad": Keypad(rig.bus, 0x15), "keybox": Keybox(rig.bus, 0x0C),
           "mt": Keypad.connect(rig.bus, 0x16)}
    rig.close()


CALLS: dict[str, Callable[[dict[str, Any], Any], object]] = {
    "keypad.monitor_heartbeat": lambda d, v: d["keypad"].monitor_heartbeat(v),
    "keybox.monitor_heartbeat": lambda d, v: d["keybox"].monitor_heartbeat(v),
    "keypad.set_heartbeat": lambda d, v: d["keypad"].set_heartbeat(v),
    "keybox.set_heartbeat": lambda d, v: d["keybox"].set_heartbeat(v),
    "keypad.watch_host": lambda d, v: d["keypad"].watch_host(v),
    "keybox.watch_host": lambda d, v: d["keybox"].watch_host(v),
    "keybox.set_consumer_heartbeat": lambda d, v: d["keybox"].set_consumer_heartbeat(0x7F, v),
    "keypad.set_periodic_key_state": lambda d, v: d["keypad"].set_periodic_key_state(v),
    "mt.set_encoder_period": lambda d, v: d["mt"].set_encoder_period(1, v),
    "mt.set_analog_period": lambda d, v: d["mt"].set_analog_period(v),
    "keybox.set_fault_period": lambda d, v: d["keybox"].set_fault_period(v),
    "keypad.monitor_heartbeat(timeout=)": lambda d, v: d["keypad"].monitor_heartbeat(0.1, v),
    "Keybox(watchdog=)": lambda d, v: Keybox(d["rig"].bus, 0x0C, watchdog=v),
    "Keypad(watchdog=)": lambda d, v: Keypad(d["rig"].bus, 0x15, watchdog=v),
    "Keybox(fault_poll=)": lambda d, v: Keybox(d["rig"].bus, 0x0C, fault_poll=v),
}
#: None is "no watchdog", "no polling" there
OPTIONAL = {"Keybox(watchdog=)", "Keypad(watchdog=)", "Keybox(fault_poll=)",
            "keypad.monitor_heartbeat(timeout=)"}


@pytest.mark.parametrize(("call", "value", "error"), [
    (call, value, error) for call in sorted(CALLS) for value, error in BAD
    if not (value is None and call in OPTIONAL)
    and not (value == 1e308 and call == "Keybox(fault_poll=)")])  # a poll that never comes
def test_a_period_that_is_not_seconds_is_refused_before_anything_is_sent(
        drivers: dict[str, Any], call: str, value: object, error: type[Exception]) -> None:
    rig = drivers["rig"]
    rig.settle()
    before = len(rig.frames)
    with pytest.raises(error, match=r"period|timeout"):
        CALLS[call](drivers, value)
    assert len(rig.frames) == before


@pytest.mark.parametrize(("call", "value", "valid"), [
    ("keypad.set_heartbeat", 0.0004, "0 or 0.01..65.279 s"),  # 0 ms: would switch it off
    ("keypad.monitor_heartbeat", 0.0004, "0 or 0.01..65.279 s"),
    ("keypad.set_periodic_key_state", 0.0004, "0 or 0.01..65.279 s"),
    ("mt.set_encoder_period", 0.0001, "0 or 0.05..65.279 s"),
    ("keybox.set_fault_period", 0.004, "0..652.79 s"),        # 10 ms units
    ("keybox.set_consumer_heartbeat", 0.0004, "0 or 0.01..65.279 s"),
    ("mt.set_analog_period", 5, "0.08..2 s"),                  # was "takes 0x8..0xc8, not 500"
    ("keybox.set_fault_period", -1, "0..652.79 s"),
    ("keypad.monitor_heartbeat(timeout=)", -1, ">= 0"),        # a "lost" at every heartbeat
])
def test_a_period_the_device_cannot_hold_is_refused_in_seconds(
        drivers: dict[str, Any], call: str, value: float, valid: str) -> None:
    """A period is refused naming the valid periods in seconds, not the object's units, and
    a positive one that rounds to no unit (what switches the thing off) is refused too."""
    rig = drivers["rig"]
    rig.settle()
    before = len(rig.frames)
    with pytest.raises(ValueError, match=r"period|timeout") as refused:
        CALLS[call](drivers, value)
    assert valid in str(refused.value)
    assert len(rig.frames) == before


@pytest.mark.parametrize("value", [1e308, -1.0, float("inf"), float("nan")])
@pytest.mark.parametrize("call", ["Keypad", "Keybox", "software_revision", "confirm",
                                  "identity"])
def test_a_wait_no_timer_can_hold_is_refused_before_anything_is_sent(
        call: str, value: float) -> None:
    """``sdo_timeout=1e308`` was taken and overflowed the platform's timer at the first SDO
    wait on a real bus; a J1939 keypad's ``software_revision(timeout=-1)`` sent its request
    and raised TimeoutError."""
    with Rig() as rig:
        rig.add(KeypadTwin(node_id=0x15, settings={"startup_led_show": 0}))
        rig.add(KeyboxTwin(node_id=0x0C))
        rig.add(KeypadTwin(node_id=0x16, protocol="j1939"))
        j1939 = Keypad(rig.bus, protocol="j1939").j1939
        assert j1939 is not None
        calls: dict[str, Callable[[], object]] = {
            "Keypad": lambda: Keypad(rig.bus, 0x15, sdo_timeout=value),
            "Keybox": lambda: Keybox(rig.bus, 0x0C, sdo_timeout=value),
            "software_revision": lambda: j1939.software_revision(value),
            "confirm": lambda: j1939.confirm(value),
            "identity": lambda: j1939.identity("pkp-2600-si", 0.5, heartbeat_wait=value),
        }
        rig.settle()
        before = len(rig.frames)
        with pytest.raises(ValueError, match=r"timeout|wait"):
            calls[call]()
        assert len(rig.frames) == before


@pytest.mark.parametrize("call", ["set_heartbeat", "monitor_heartbeat", "set_periodic_key_state"])
@pytest.mark.parametrize("period", [0.02, 3.0])
def test_a_j1939_period_is_refused_in_seconds(call: str, period: float) -> None:
    """In J1939 mode the periods are §17/§18's bytes (x 10 ms, 05h..FEh): a period outside
    was refused as "heartbeat period must be 0x5..0xfe, not 0x2", in the command's units."""
    with Rig() as rig:
        rig.add(KeypadTwin(node_id=0x15, protocol="j1939"))
        keypad = Keypad(rig.bus, protocol="j1939")
        rig.settle()
        before = len(rig.frames)
        with pytest.raises(ValueError, match="period") as refused:
            getattr(keypad, call)(period)
        assert "0.05..2.54 s" in str(refused.value)
        assert f"not {period:g}" in str(refused.value)
        assert len(rig.frames) == before
