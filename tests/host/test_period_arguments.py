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
       (True, TypeError), ("3", TypeError), (None, TypeError)]


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
    "Keybox(watchdog=)": lambda d, v: Keybox(d["rig"].bus, 0x0C, watchdog=v),
    "Keypad(watchdog=)": lambda d, v: Keypad(d["rig"].bus, 0x15, watchdog=v),
    "Keybox(fault_poll=)": lambda d, v: Keybox(d["rig"].bus, 0x0C, fault_poll=v),
}
#: None is "no watchdog", "no polling" there
OPTIONAL = {"Keybox(watchdog=)", "Keypad(watchdog=)", "Keybox(fault_poll=)"}


@pytest.mark.parametrize(("call", "value", "error"), [
    (call, value, error) for call in sorted(CALLS) for value, error in BAD
    if not (value is None and call in OPTIONAL)])
def test_a_period_that_is_not_seconds_is_refused_before_anything_is_sent(
        drivers: dict[str, Any], call: str, value: object, error: type[Exception]) -> None:
    rig = drivers["rig"]
    rig.settle()
    before = len(rig.frames)
    with pytest.raises(error, match="period"):
        CALLS[call](drivers, value)
    assert len(rig.frames) == before
