"""Drivers a controller can trust (issue #10): every FAULT transition and every health change is
an event, the output picture follows the device, restores never race the application.

In simulated time (``sim``), so watchdog trips are deterministic; the test that needs two
threads racing for the SDO channel runs on a real bus (``rig``)."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterator

import pytest

from blinkcan.host import FaultEvent, HealthEvent, Keybox, Keypad
from blinkcan.protocol.nmt import NmtState
from tests.host.conftest import FLAVOUR_IDS, FLAVOURS, Rig, simulated_rig, wait_until


@pytest.fixture(params=FLAVOURS, ids=FLAVOUR_IDS)
def sim(request: pytest.FixtureRequest) -> Iterator[Rig]:
    yield from simulated_rig(request)


def _until(events: Iterator[HealthEvent], kind: str) -> list[HealthEvent]:
    """Events up to and including the first of ``kind``."""
    seen = []
    for event in events:
        seen.append(event)
        if event.kind == kind:
            return seen
    raise AssertionError(f"no {kind!r} event; saw {[e.kind for e in seen]}")


def _hold_blocking_work(rig: Rig, monkeypatch: pytest.MonkeyPatch
                        ) -> list[Callable[[], object]]:
    """Hold back the blocking work drivers hand off (``host.spawn``), to run it when the test
    says."""
    held: list[Callable[[], object]] = []
    monkeypatch.setattr(rig.host, "spawn", lambda action, key=None: held.append(action))
    return held


# -- item 2: every FAULT transition of every pin, in order --------------------------------------

def test_every_fault_transition_of_a_pin_is_an_event_in_order(sim: Rig) -> None:
    keybox = Keybox(sim.host)
    seen: list[FaultEvent] = []
    keybox.on_fault(seen.append)
    keybox.on(6)
    sim.emulator.run(lambda now: sim.keybox.blow_fuse(6, now))
    sim.wait_until(lambda: len(seen) == 1)
    keybox.reset(6)  # out of FAULT, the fuse still blown
    keybox.on(6)  # into the blown fuse: FAULT again
    sim.wait_until(lambda: len(seen) == 3)
    sim.emulator.run(lambda now: sim.keybox.replace_fuse(6, now))
    keybox.reset(6)
    keybox.on(6)
    sim.emulator.run(lambda now: sim.keybox.blow_fuse(6, now))  # the new fuse blows too
    sim.wait_until(lambda: len(seen) == 5)
    assert keybox.fault_pins == {6}
    sim.emulator.power_cycle(sim.keybox)  # a power cycle clears the latch
    sim.wait_until(lambda: len(seen) == 6)
    assert [(e.pin, e.fault) for e in seen] == [
        (6, True), (6, False), (6, True), (6, False), (6, True), (6, False)]
    assert keybox.fault_pins == frozenset()


def test_a_state_read_keeps_the_fault_picture_true(sim: Rig) -> None:
    keybox = Keybox(sim.host, start=False)  # pre-operational: no fault PDO (KBX §18)
    seen: list[FaultEvent] = []
    keybox.on_fault(seen.append)
    keybox.on(2)
    sim.emulator.run(lambda now: sim.keybox.blow_fuse(2, now))
    assert keybox.states()[2] == "fault"
    assert [(e.pin, e.fault) for e in seen] == [(2, True)]
    assert keybox.actual[2] == "fault"


# -- item 3: health events, the output picture, restores -----------------------------------------

def test_every_reported_nmt_state_and_a_boot_up_are_health_events(sim: Rig) -> None:
    keybox = Keybox(sim.host, start=False)
    events = keybox.health_events(timeout=2.0)
    keybox.monitor_heartbeat(0.05)
    assert _until(events, "state")[-1].state is NmtState.PRE_OPERATIONAL
    keybox.on(3)
    keybox.start()
    assert _until(events, "state")[-1].state is NmtState.OPERATIONAL
    keybox.stop()
    assert _until(events, "state")[-1].state is NmtState.STOPPED
    assert keybox.actual[3] == "off"  # fail-safe: a stopped Keybox switches outputs off
    keybox.enter_pre_operational()
    kinds = [e.kind for e in _until(events, "state")]
    assert "watchdog" not in kinds  # asked for: not a trip
    sim.emulator.power_cycle(sim.keybox)
    assert [e.kind for e in _until(events, "boot-up")][-1] == "boot-up"


def test_a_watchdog_trip_is_an_event_and_the_picture_follows_the_device(sim: Rig) -> None:
    keybox = Keybox(sim.host, watchdog=0.15)  # margin: a busy machine delays heartbeats
    events = keybox.health_events(timeout=3.0)
    keybox.on(4)
    assert (keybox.commanded, keybox.actual[4]) == (frozenset({4}), "high")
    sim.sleep(0.4)  # the device has heard the host: it watches from the first heartbeat
    keybox.stop_host_heartbeat()
    trip = _until(events, "watchdog")[-1]
    assert trip.state is NmtState.PRE_OPERATIONAL
    assert keybox.actual[4] == "off"  # the Keybox switched it off
    assert keybox.commanded == {4}  # what the application asked is kept
    sim.sleep(0.1)
    assert keybox.state(4) == "off"  # not re-energised unasked


def test_a_watchdog_trip_restores_outputs_when_asked(sim: Rig) -> None:
    keybox = Keybox(sim.host, watchdog=0.15, restore_outputs=True)
    events = keybox.health_events(timeout=3.0)
    keybox.set_outputs(high=[3, 5])
    sim.sleep(0.4)  # the device has heard the host: it watches from the first heartbeat
    keybox.stop_host_heartbeat()
    _until(events, "watchdog")
    keybox.watch_host(0.15)  # restored once the Keybox watches again (issue 17 item 9)
    sim.wait_until(lambda: {p for p, s in keybox.states().items() if s == "high"} == {3, 5})
    assert {p for p, s in keybox.actual.items() if s == "high"} == {3, 5}


def test_a_restore_never_switches_back_on_what_the_application_switched_off(
        sim: Rig, monkeypatch: pytest.MonkeyPatch) -> None:
    keybox = Keybox(sim.host, restore_outputs=True)
    keybox.set_outputs(high=[4, 6])
    held = _hold_blocking_work(sim, monkeypatch)
    sim.emulator.power_cycle(sim.keybox)
    sim.wait_until(lambda: held)  # the driver has planned its restore
    keybox.off(4)  # ... and the application switches 4 off before the restore runs
    for work in held:
        work()
    assert {p for p, s in keybox.states().items() if s == "high"} == {6}


def test_the_keypad_restore_never_writes_a_stale_backlight_colour(
        rig: Rig, monkeypatch: pytest.MonkeyPatch) -> None:
    keypad = Keypad(rig.host)
    keypad.set_backlight("blue", 20)
    held = _hold_blocking_work(rig, monkeypatch)
    rig.emulator.power_cycle(rig.keypad)
    wait_until(lambda: held)
    rig.emulator.response_delay = 0.3  # the application's write is slow to be acknowledged
    application = threading.Thread(target=lambda: keypad.set_backlight("red"))
    application.start()
    time.sleep(0.1)  # its write is in flight when the restore runs
    restore = [threading.Thread(target=work) for work in held]
    for thread in restore:
        thread.start()
    application.join()
    for thread in restore:
        thread.join()
    rig.emulator.response_delay = 0.0
    wait_until(lambda: rig.emulator.snapshot(rig.keypad)["backlight"]["colour"] == "red")
    time.sleep(0.05)
    assert rig.emulator.snapshot(rig.keypad)["backlight"] == {"colour": "red", "level": 20}


def test_the_output_picture_matches_the_keybox(sim: Rig) -> None:
    keybox = Keybox(sim.host)
    steps: list[Callable[[], None]] = [
        lambda: keybox.on(1), lambda: keybox.set_outputs(high=[2, 3], off=[1]),
        lambda: keybox.set_pwm([12], 5), lambda: keybox.set_pwm([13], 0),
        lambda: keybox.on(13), lambda: keybox.set_pwm([12, 13], 3),
        lambda: keybox.off(12), keybox.stop]
    for step in steps:
        step()
        sim.sleep(0.01)
        shown = {pin["pin"]: pin["state"] for pin in sim.emulator.snapshot(sim.keybox)["pins"]}
        assert keybox.actual == shown  # no read needed: the driver kept it
    assert keybox.commanded == {2, 3}  # PWM is not a HIGH command; a stop keeps the intent


# -- item 10: the consumer heartbeat range, from devices/ ------------------------------------------

def test_driver_and_twin_agree_on_the_consumer_heartbeat_range(sim: Rig) -> None:
    keybox = Keybox(sim.host)
    with pytest.raises(ValueError, match=r"0\.01\.\.65\.279 s"):
        keybox.set_consumer_heartbeat(0x7F, 65.535)  # KBX §28: 10..65279 ms
    if sim.generation == "1.5":
        keypad = Keypad(sim.host)
        keypad.set_consumer_heartbeat(0x7F, 65.535)  # errata G4: 10..65535 ms
        consumer = sim.emulator.snapshot(sim.keypad)["heartbeat_consumer"]
        assert consumer == {"node_id": 0x7F, "time_ms": 65535, "state": "waiting"}


def test_a_generation_2_keypad_gets_its_leds_back_after_a_watchdog_trip(sim: Rig) -> None:
    if sim.generation != "1.5":
        pytest.skip("generation 1 has no consumer heartbeat")
    keypad = Keypad(sim.host, watchdog=0.15)  # restore=True: the default
    keypad.set_led(7, "red")
    events = keypad.health_events(timeout=3.0)
    sim.sleep(0.4)  # the device has heard the host: it watches from the first heartbeat
    keypad.stop_host_heartbeat()
    trip = _until(events, "watchdog")[-1]
    assert trip.state is NmtState.PRE_OPERATIONAL
    sim.wait_until(lambda: sim.emulator.snapshot(sim.keypad)["keys"][6]["colour"] == "red")
    assert sim.emulator.snapshot(sim.keypad)["nmt_state"] == "operational"


def test_an_uncertain_off_is_never_switched_back_on_by_a_restore() -> None:
    # an off(4) the Keybox may not have applied (it was away: SdoTimeoutError, uncertain)
    # still means "4 must not be on": the restore after its reboot fails safe
    from blinkcan.host import SdoTimeoutError
    from blinkcan.testing import Rig as SimulatedRig
    from blinkcan.twin import KeyboxTwin

    rig = SimulatedRig()
    try:
        twin = rig.add(KeyboxTwin(node_id=0x0C))
        keybox = Keybox(rig.bus, 0x0C, restore_outputs=True)
        keybox.set_outputs(high=[4, 6])
        rig.power_off(twin)
        with pytest.raises(SdoTimeoutError):
            keybox.off(4)
        assert 4 not in keybox.commanded
        rig.power_on(twin)
        rig.advance(2.0)
        states = {pin["pin"]: pin["state"] for pin in twin.snapshot()["pins"]}
        assert (states[4], states[6]) == ("off", "high")
    finally:
        rig.close()
