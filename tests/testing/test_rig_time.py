"""Simulated time never hangs and takes only finite times (issue 17 items 1 and 2)."""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from typing import Any

import can
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from blinkcan.devices.model import Model
from blinkcan.protocol import Frame
from blinkcan.runtime import Emulator
from blinkcan.runtime.scheduler import (
    RealTimeScheduler,
    SimulatedScheduler,
    StuckDeadlineError,
)
from blinkcan.testing import Rig
from blinkcan.twin import KeyboxTwin, KeypadTwin
from tests.twin.test_schedules import IDS, STEPS, VARIANTS, build, operation

SWITCH_TO_J1939 = Frame(0x615, bytes.fromhex("2BFF200101000000"))  # 20FFh/01 = 1 (J-1)
#: J1939 "switch to CANopen" (§27) to all, from address 80h
SWITCH_TO_CANOPEN = Frame(0x18EFFF80, bytes.fromhex("041B8000FFFFFFFF"), extended=True)


def test_a_factory_keypad_power_cycled_at_two_seconds_lets_time_run_on() -> None:
    """Issue 17: rig.now stopped at 4.56 s with 100 % CPU (the start-up show's last step)."""
    with Rig() as rig:
        keypad = rig.add(KeypadTwin())
        rig.advance(2.0)
        rig.power_cycle(keypad)
        rig.advance(5.0)
        assert rig.now == pytest.approx(7.1)
        assert keypad.snapshot()["startup_show"] is None


@pytest.mark.parametrize("manual", ["1.1", "1.5"])
def test_a_keypad_switched_to_j1939_and_back_lets_time_run_on(manual: str) -> None:
    with Rig() as rig:
        keypad = rig.add(KeypadTwin(manual=manual))
        rig.advance(2.0)
        rig.bus.send(can.Message(arbitration_id=0x615, data=SWITCH_TO_J1939.data,
                                 is_extended_id=False))
        rig.advance(5.0)
        assert keypad.protocol == "j1939"
        rig.bus.send(can.Message(arbitration_id=SWITCH_TO_CANOPEN.can_id,
                                 data=SWITCH_TO_CANOPEN.data, is_extended_id=True))
        rig.advance(5.0)
        assert keypad.protocol == "canopen"
        assert rig.now == pytest.approx(12.0)


class _Stuck(KeyboxTwin):
    """A broken twin: it names a deadline that advance() never consumes."""

    advances = 0

    def advance(self, now: float) -> list[Frame]:
        self.advances += 1
        return super().advance(now)

    def next_deadline(self) -> float | None:
        return 1.5 if self.powered else None


def test_the_simulation_refuses_to_spin_on_a_deadline_that_does_not_move() -> None:
    with Rig() as rig:
        twin = rig.add(_Stuck())
        with pytest.raises(StuckDeadlineError, match=r"_Stuck at node 0Ch .*1\.5"):
            rig.advance(3.0)
        assert rig.now == 1.5  # raised from the call that ran into it, at that time
        assert twin.advances == 1
        twin.power_off()  # so closing the rig does not ask it again


def test_real_time_does_not_spin_on_a_deadline_that_does_not_move(
        caplog: pytest.LogCaptureFixture) -> None:
    """Asked again at most every millisecond (a spin asks millions of times a second)."""
    twin = _Stuck()
    twin.next_deadline = lambda: 0.0 if twin.powered else None  # type: ignore[method-assign]
    bus = can.Bus(interface="virtual", channel=f"h17a-stuck-{id(twin)}")
    try:
        with Emulator(bus, [twin]):
            time.sleep(0.3)
        assert 1 <= twin.advances <= 600
        assert "did not consume" in caplog.text
    finally:
        bus.shutdown()


NAN, INF = math.nan, math.inf


def _rig_calls() -> dict[str, Callable[[Rig, Any], object]]:
    return {
        "advance": lambda rig, t: rig.advance(t),
        "settle": lambda rig, t: rig.settle(t),
        "until": lambda rig, t: rig.until(lambda: False, t),
        "busy": lambda rig, t: rig.busy(t),
        "delay": lambda rig, t: rig.delay(lambda frame: True, t),
        "power_cycle": lambda rig, t: rig.power_cycle(rig.twins[0], off_time=t),
        "tap": lambda rig, t: rig.tap(rig.twins[0], 1, hold=t),
        "long_press": lambda rig, t: rig.long_press(rig.twins[0], 1, hold=t),
        "frames_since": lambda rig, t: rig.frames_since(t),
        "twin.power_on": lambda rig, t: rig.twins[0].power_on(t),
        "twin.receive": lambda rig, t: rig.twins[0].receive(Frame(0, b"\x01\x00"), t),
        "twin.advance": lambda rig, t: rig.twins[0].advance(t),
        "twin.press": lambda rig, t: rig.twins[0].press(1, t),
        "twin.reset_node": lambda rig, t: rig.twins[0].reset_node(t),
        "keypad.displayed_leds": lambda rig, t: rig.twins[0].displayed_leds(t),
        "scheduler.step": lambda rig, t: rig.scheduler.step(t),
        "keybox.blow_fuse": lambda rig, t: rig.twins[1].blow_fuse(1, t),
        "keybox.set_input": lambda rig, t: rig.twins[1].set_input(1, True, t),
        "scheduler.call_later": lambda rig, t: rig.scheduler.call_later(t, lambda: None),
        "scheduler.call_at": lambda rig, t: rig.scheduler.call_at(t, lambda: None),
        "scheduler.call_every": lambda rig, t: rig.scheduler.call_every(t, lambda: None),
        "scheduler.call_every first": lambda rig, t: rig.scheduler.call_every(
            1.0, lambda: None, first=t),
        "scheduler.sleep": lambda rig, t: rig.scheduler.sleep(t),
        "scheduler.wait": lambda rig, t: rig.scheduler.wait(rig.scheduler.signal(), t),
        "scheduler.run_until": lambda rig, t: rig.scheduler.run_until(None, t),
        "bus.recv": lambda rig, t: rig.bus.recv(t),
    }


#: calls where +inf means something (no end): only NaN is refused there
INFINITE_OK = {"scheduler.wait", "scheduler.run_until", "scheduler.step", "bus.recv"}


@pytest.mark.parametrize("value", [NAN, INF, -INF], ids=["nan", "inf", "-inf"])
@pytest.mark.parametrize("call", list(_rig_calls()))
def test_a_non_finite_time_is_a_value_error(call: str, value: float) -> None:
    if value == INF and call in INFINITE_OK:
        pytest.skip("+inf means no end here")
    with Rig() as rig:
        rig.add(KeypadTwin(settings={"startup_led_show": 0}))
        rig.add(KeyboxTwin())
        rig.advance(0.5)
        before = rig.now
        with pytest.raises(ValueError, match=r"finite|seconds"):
            _rig_calls()[call](rig, value)
        assert rig.now == before


@pytest.mark.parametrize("argument", ["start", "latency", "response_delay"])
@pytest.mark.parametrize("value", [NAN, INF], ids=["nan", "inf"])
def test_a_rig_is_not_built_with_a_non_finite_time(argument: str, value: float) -> None:
    with pytest.raises(ValueError, match=argument):
        Rig(**{argument: value})


@pytest.mark.parametrize("value", [NAN, INF], ids=["nan", "inf"])
def test_schedulers_and_emulators_refuse_non_finite_times(value: float) -> None:
    with pytest.raises(ValueError, match="start"):
        SimulatedScheduler(value)
    with pytest.raises(ValueError, match="delay"):
        RealTimeScheduler().call_later(value, lambda: None)
    bus = can.Bus(interface="virtual", channel="h17a-never-started")
    try:
        with pytest.raises(ValueError, match="response_delay"):
            Emulator(bus, [], response_delay=value)
    finally:
        bus.shutdown()


@pytest.mark.parametrize(("model", "generation", "protocol"), VARIANTS, ids=IDS)
@settings(max_examples=15, deadline=None)
@given(data=st.data())
def test_a_rig_runs_every_twin_at_random_times_and_time_always_advances(
        model: Model, generation: str, protocol: str, data: st.DataObject) -> None:
    """The emulator's side of tests/twin/test_schedules.py: the same random life of every
    registered model, generation and protocol on a Rig; each advance ends where it should."""
    with Rig() as rig:
        twin = rig.add(build(model, generation, protocol))
        for _ in range(data.draw(st.integers(1, 8), "actions")):
            step = data.draw(STEPS, "wait")
            target = rig.now + step
            rig.advance(step)
            assert rig.now == target
            if data.draw(st.integers(0, 4), "power cycle?") == 0:
                rig.power_cycle(twin, off_time=data.draw(STEPS, "off time"))
                continue
            _, action = data.draw(operation(twin), "action")
            rig.act(action)
        target = rig.now + 6.0
        rig.advance(6.0)
        assert rig.now == target
