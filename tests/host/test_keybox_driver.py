"""The Keybox driver against the Keybox twin, in both quirk profiles, in simulated time."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from blinkcan.host import FaultEvent, Keybox
from tests.host.conftest import Rig, simulated_rig


@pytest.fixture(params=[("firmware", "1.1"), ("cia301", "1.1")], ids=["firmware", "cia301"])
def rig(request: pytest.FixtureRequest) -> Iterator[Rig]:
    yield from simulated_rig(request)


def test_outputs_states_pwm_and_inputs(rig: Rig) -> None:
    keybox = Keybox(rig.host)
    keybox.on(1)
    keybox.set_outputs(high=[2, 3, 9])
    keybox.off(3)
    keybox.set_pwm([12], 5)
    states = keybox.states()
    assert {p for p, s in states.items() if s == "high"} == {1, 2, 9, 12}
    assert keybox.state(3) == "off"
    rig.emulator.run(lambda now: rig.keybox.set_input(5, True, now))
    inputs = keybox.inputs()
    assert {p for p, level in inputs.items() if level} == {1, 2, 5, 9, 12}


def test_a_blown_fuse_raises_a_fault_event_and_reset_clears_it(rig: Rig) -> None:
    keybox = Keybox(rig.host, fault_poll=0.05)
    keybox.on(6)
    events = keybox.fault_events(timeout=1.0)
    rig.emulator.run(lambda now: rig.keybox.blow_fuse(6, now))
    event = next(events)
    assert (event.pin, event.fault) == (6, True)
    assert keybox.state(6) == "fault"
    rig.emulator.run(lambda now: rig.keybox.replace_fuse(6, now))
    keybox.reset(6)
    event = next(events)  # the poll notices the pin left FAULT
    assert (event.pin, event.fault) == (6, False)
    assert keybox.state(6) == "off"


def test_outputs_go_off_when_the_host_heartbeat_stops(rig: Rig) -> None:
    keybox = Keybox(rig.host, watchdog=0.15)  # margin: a busy machine delays heartbeats
    keybox.on(4)
    rig.sleep(0.4)  # the heartbeat keeps it on
    assert keybox.state(4) == "high"
    events = keybox.health_events(timeout=2.0)
    keybox.stop_host_heartbeat()
    assert any(e.kind == "watchdog" for e in events)  # the driver saw the trip
    assert keybox.state(4) == "off"


def test_configuration_and_restore_defaults(rig: Rig) -> None:
    keybox = Keybox(rig.host)
    keybox.set_fault_period(0.1)
    keybox.set_bitrate(250_000, confirm=True)  # errata B1: Keybox code 01h
    settings = rig.emulator.snapshot(rig.keybox)["settings"]
    assert (settings["fault_period"], settings["baud_rate"]) == (10, 1)
    keybox.restore_factory_defaults(confirm=True)  # 43h acknowledge in the firmware profile
    settings = rig.emulator.snapshot(rig.keybox)["settings"]
    assert (settings["fault_period"], settings["baud_rate"]) == (0, 0)


def test_fault_events_reach_callbacks(rig: Rig) -> None:
    keybox = Keybox(rig.host)
    seen: list[FaultEvent] = []
    keybox.on_fault(seen.append)
    keybox.set_outputs(high=[10, 11])
    rig.emulator.run(lambda now: rig.keybox.blow_fuse(10, now))
    rig.emulator.run(lambda now: rig.keybox.blow_fuse(11, now))
    rig.wait_until(lambda: len(seen) == 2)
    assert [(e.pin, e.fault) for e in seen] == [(10, True), (11, True)]


@pytest.mark.parametrize(("call", "message"), [
    (lambda k: k.on(0), r"pin 0 outside 1..13"),
    (lambda k: k.off(14), r"pin 14 outside 1..13"),
    (lambda k: k.set_pwm([3], 5), r"PWM is on pins \(12, 13\) only"),
    (lambda k: k.set_pwm([12], 11), r"PWM duty 11 outside 0..10"),
    (lambda k: k.set_outputs(high=[1], off=[1]), r"asked HIGH and OFF"),
    (lambda k: k.set_bitrate(125_000), r"confirm=True"),
    (lambda k: k.set_bitrate(1_000_000, confirm=True), r"does not run at 1000000"),
    (lambda k: k.restore_factory_defaults(), r"confirm=True"),
    (lambda k: k.set_consumer_heartbeat(1, 0.005), r"0.01..65.279"),
])
def test_misuse_raises_and_sends_nothing(rig: Rig, call: object, message: str) -> None:
    keybox = Keybox(rig.host, start=False)
    rig.sniffed()
    with pytest.raises(ValueError, match=message):
        call(keybox)  # type: ignore[operator]
    assert rig.sniffed() == []
