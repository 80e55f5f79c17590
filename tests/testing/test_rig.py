"""The testing kit: simulated time, the Rig, fault injection, golden traces."""

from __future__ import annotations

from pathlib import Path

import can
import pytest

from blinkcan import Keybox, Keypad
from blinkcan.host import KeyEvent, SdoTimeoutError
from blinkcan.protocol import Frame
from blinkcan.runtime.scheduler import SimulatedScheduler
from blinkcan.testing import Rig, TimedFrame, assert_matches_trace, frames_of, record_trace
from blinkcan.twin import KeyboxTwin, KeypadTwin


def test_simulated_scheduler_runs_events_in_time_then_schedule_order() -> None:
    scheduler = SimulatedScheduler()
    seen: list[tuple[float, str]] = []
    scheduler.call_later(0.2, lambda: seen.append((scheduler.clock(), "b")))
    scheduler.call_later(0.1, lambda: seen.append((scheduler.clock(), "a")))
    scheduler.call_later(0.2, lambda: seen.append((scheduler.clock(), "c")))
    scheduler.call_every(0.15, lambda: seen.append((scheduler.clock(), "tick")), first=0.15)
    scheduler.run_until(None, 0.31)
    assert seen == [(0.1, "a"), (0.15, "tick"), (0.2, "b"), (0.2, "c"), (0.3, "tick")]
    assert scheduler.clock() == 0.31


def test_deferred_calls_take_their_turn_among_timers_in_schedule_order() -> None:
    """The wire hands frames over with defer(), not timers: the order must be the same."""
    scheduler = SimulatedScheduler()
    seen: list[tuple[float, str]] = []

    def note(what: str) -> None:
        seen.append((scheduler.clock(), what))

    def at_one_tenth() -> None:
        note("timer")
        scheduler.call_soon(lambda: note("soon 1"))
        scheduler.defer(note, "deferred 1")
        scheduler.call_soon(lambda: note("soon 2"))
        scheduler.defer(note, "deferred 2")
        scheduler.call_later(0.0, lambda: note("later 0"))

    scheduler.call_later(0.1, at_one_tenth)
    scheduler.call_later(0.1, lambda: note("timer 2"))  # scheduled before the calls above
    scheduler.defer(note, "deferred now")
    assert scheduler.next_due() == 0.0
    assert scheduler.run_until(lambda: len(seen) == 4, 1.0)  # the predicate between events
    assert seen == [(0.0, "deferred now"), (0.1, "timer"), (0.1, "timer 2"), (0.1, "soon 1")]
    assert scheduler.next_due() == 0.1
    scheduler.run_until(None, 0.1)
    assert [what for _, what in seen[4:]] == ["deferred 1", "soon 2", "deferred 2", "later 0"]
    assert scheduler.next_due() is None
    scheduler.defer(note, "not before its time")
    assert not scheduler.step(0.05)  # the clock never goes back: nothing is due by 0.05
    assert scheduler.step(0.1)
    assert seen[-1] == (0.1, "not before its time")


def test_a_wait_runs_the_simulation_until_its_signal_or_its_virtual_timeout() -> None:
    scheduler = SimulatedScheduler()
    signal = scheduler.signal()
    scheduler.call_later(0.3, signal.set)
    assert scheduler.wait(signal, 1.0)
    assert scheduler.clock() == 0.3
    assert not scheduler.wait(scheduler.signal(), 0.5)
    assert scheduler.clock() == 0.8


def test_background_work_never_runs_inside_a_wait() -> None:
    scheduler = SimulatedScheduler()
    order: list[str] = []
    signal = scheduler.signal()

    def handler() -> None:
        scheduler.spawn(lambda: order.append("background"))
        order.append("handler")

    scheduler.call_later(0.1, handler)
    scheduler.call_later(0.2, signal.set)
    scheduler.wait(signal, 1.0)
    order.append("wait returned")
    scheduler.run_until(None, scheduler.clock())
    assert order == ["handler", "wait returned", "background"]


def _scenario() -> list[TimedFrame]:
    with Rig() as rig:
        keypad_twin = rig.add(KeypadTwin(node_id=0x15))
        keybox_twin = rig.add(KeyboxTwin(node_id=0x0C))
        keypad, keybox = Keypad(rig.bus, 0x15), Keybox(rig.bus, 0x0C, watchdog=0.1)
        keypad.set_heartbeat(0.05)
        rig.tap(keypad_twin, 3, hold=0.9)
        keybox.on(3)
        rig.blow_fuse(keybox_twin, 3)
        rig.advance(0.5)
        keybox.stop_host_heartbeat()
        rig.advance(0.5)
        keypad.close()
        keybox.close()
        return list(rig.frames)


def test_the_same_scenario_gives_the_same_frames_at_the_same_times() -> None:
    first = _scenario()
    assert len(first) > 40
    for _ in range(19):
        assert _scenario() == first


def test_watchdog_trip_in_virtual_time() -> None:
    with Rig() as rig:
        twin = rig.add(KeyboxTwin(node_id=0x0C))
        keybox = Keybox(rig.bus, 0x0C, watchdog=0.1)
        keybox.on(4)
        rig.advance(1.0)
        assert twin.snapshot()["pins"][3]["state"] == "high"
        keybox.stop_host_heartbeat()
        tripped = rig.until(lambda: twin.snapshot()["pins"][3]["state"] == "off", timeout=1.0)
        # KBX §28: consumer time 2 x 0.1 s after the last heartbeat (sent at 1.0 s)
        assert 1.2 <= tripped <= 1.21
        keybox.close()


def test_long_press_in_virtual_time() -> None:
    with Rig() as rig:
        twin = rig.add(KeypadTwin(node_id=0x15))
        keypad = Keypad(rig.bus, 0x15, long_press=0.8)
        events: list[KeyEvent] = []
        keypad.keys.subscribe(events.append)
        rig.settle()
        start = rig.now
        rig.long_press(twin, 5, hold=1.0)
        assert [(e.action, round(e.time - start, 6)) for e in events] == [
            ("press", 0.0), ("long press", 0.8), ("release", 1.0)]
        keypad.close()


def test_iterating_events_runs_the_simulation() -> None:
    with Rig() as rig:
        twin = rig.add(KeypadTwin(node_id=0x15))
        keypad = Keypad(rig.bus, 0x15)
        rig.scheduler.call_later(0.5, lambda: rig.press(twin, 2))
        event = next(keypad.events(timeout=1.0))
        assert (event.key, event.action, event.time) == (2, "press", 0.5)
        assert list(keypad.events(timeout=0.2)) == []
        keypad.close()


def test_twins_can_be_built_as_configured() -> None:
    twin = KeypadTwin(settings={"startup_led_show": 0, "producer_heartbeat_time": 50})
    frames = twin.power_on(0.0)
    assert frames == [Frame(0x715, b"\x00")]
    assert twin.snapshot()["startup_show"] is None
    assert twin.advance(0.05) == [Frame(0x715, b"\x7f")]
    with pytest.raises(ValueError, match=r"not a stored setting.*startup_led_show"):
        KeypadTwin(settings={"show": 0})
    with pytest.raises(ValueError, match="producer_heartbeat_time takes"):
        KeypadTwin(settings={"producer_heartbeat_time": -1})


def test_snapshot_tells_the_startup_show_from_what_was_commanded() -> None:
    twin = KeypadTwin()
    twin.power_on(0.0)
    twin.receive(Frame(0x000, b"\x01\x15"), 0.0)
    twin.receive(Frame(0x215, bytes.fromhex("0100000000")), 0.1)  # red 1
    snapshot = twin.snapshot()
    assert snapshot["startup_show"] is not None
    assert snapshot["commanded"][0]["colour"] == "red"


def test_fault_injection_on_the_wire() -> None:
    with Rig() as rig:
        twin = rig.add(KeypadTwin(node_id=0x15, settings={"producer_heartbeat_time": 100}))
        restore = rig.stop_heartbeat(0x15)
        start = rig.now
        rig.advance(1.0)
        assert not [f for t, f in rig.frames if t > start and f.can_id == 0x715]
        restore()
        rig.advance(0.25)
        assert [f for t, f in rig.frames if t > start and f.can_id == 0x715]
        rig.bus.send(can.Message(arbitration_id=0x000, data=[1, 0x15], is_extended_id=False))
        rig.settle()
        stop_delay = rig.delay(lambda frame: frame.can_id == 0x195, 0.05)
        rig.press(twin, 1)
        pressed = rig.now
        rig.advance(0.1)
        assert [t for t, f in rig.frames if f.can_id == 0x195] == [pytest.approx(pressed + 0.05)]
        stop_delay()
        rig.bus_down()
        with pytest.raises(can.CanOperationError):
            rig.bus.send(can.Message(arbitration_id=0x000, data=[1, 0], is_extended_id=False))
        rig.bus_up()


def test_the_controller_bus_is_a_python_can_bus() -> None:
    with Rig() as rig:
        rig.add(KeypadTwin(node_id=0x15))
        rig.bus.send(can.Message(arbitration_id=0x615, data=bytes.fromhex("4000100000000000"),
                                 is_extended_id=False))
        reply = rig.bus.recv(timeout=0.1)
        while reply is not None and reply.arbitration_id != 0x595:
            reply = rig.bus.recv(timeout=0.1)
        assert reply is not None
        assert bytes(reply.data) == bytes.fromhex("4300100091010B00")


def test_golden_trace_round_trip_and_mismatch(tmp_path: Path) -> None:
    frames = _scenario()
    trace = tmp_path / "scenario.log"
    assert record_trace(frames, trace) == len(frames)
    assert_matches_trace(frames, trace)
    shifted = [TimedFrame(t + 0.002 if i == 5 else t, f) for i, (t, f) in enumerate(frames)]
    with pytest.raises(AssertionError, match="frame 5"):
        assert_matches_trace(shifted, trace)
    with pytest.raises(AssertionError, match="the trace has"):
        assert_matches_trace(frames[:-1], trace)
    assert frames_of(frames[:1]) == [frames[0].frame]
    at = next(i for i in range(len(frames) - 1) if frames[i].time == frames[i + 1].time
              and frames[i].frame != frames[i + 1].frame)
    swapped = [*frames[:at], frames[at + 1], frames[at], *frames[at + 2:]]
    with pytest.raises(AssertionError, match=f"frame {at}: .*same frames at this instant in "
                                             "another order.*--blinkcan-record"):
        assert_matches_trace(swapped, trace)


def test_no_endpoint_receives_its_own_frames() -> None:
    with Rig() as rig:
        rig.add(KeypadTwin(node_id=0x15))
        rig.settle()
        rig.bus.clear_received()
        rig.bus.send(can.Message(arbitration_id=0x000, data=[1, 0x15], is_extended_id=False))
        rig.advance(0.1)
        received = []
        while (message := rig.bus.recv(0)) is not None:
            received.append(message.arbitration_id)
        assert 0x000 not in received
        assert rig.emulator.stats.frames_received == 1  # the twins heard the NMT start once


def test_recv_without_timeout_ends_after_a_virtual_minute() -> None:
    with Rig() as rig:
        rig.add(KeyboxTwin(node_id=0x0C))
        rig.settle()
        rig.bus.clear_received()
        rig.bus.send(can.Message(arbitration_id=0x60C, data=bytes.fromhex("4000100000000000"),
                                 is_extended_id=False))
        reply = rig.bus.recv()
        assert reply is not None
        assert reply.arbitration_id == 0x58C
        start = rig.now
        assert rig.bus.recv() is None  # nothing more will come: no endless wait
        assert rig.now == start + 60.0


def test_a_closed_bus_fails_the_command_and_leaves_the_channel_usable() -> None:
    with Rig() as rig:
        twin = rig.add(KeyboxTwin(node_id=0x0C))
        keybox = Keybox(rig.bus, 0x0C)
        rig.bus_down()
        with pytest.raises(can.CanOperationError):
            keybox.on(4)
        rig.bus_up()
        keybox.on(4)
        assert twin.snapshot()["pins"][3]["state"] == "high"
        keybox.close()


def test_a_reboot_in_the_middle_of_a_command_is_never_reported_as_success() -> None:
    with Rig() as rig:
        twin = rig.add(KeyboxTwin(node_id=0x0C))
        keybox = Keybox(rig.bus, 0x0C, sdo_timeout=0.2)

        def reboot_on_request(frame: Frame) -> str | None:
            if frame.can_id == 0x60C and frame.data[:4] == bytes.fromhex("2F012004"):
                rig.scheduler.call_soon(lambda: rig.power_off(twin))
                rig.scheduler.call_later(0.5, lambda: rig.power_on(twin))
                return "drop"  # the Keybox lost power as the request arrived
            return None

        undo = rig.network.add_rule(reboot_on_request)
        with pytest.raises(SdoTimeoutError):
            keybox.on(4)
        undo()
        rig.advance(1.0)
        assert keybox.state(4) == "off"  # what the rebooted Keybox really does
        keybox.close()


def _keypad_models() -> list[str]:
    from blinkcan.devices.registry import load_class, models

    return [model.name for model in models()
            if issubclass(load_class(model.twin, object), KeypadTwin)]


@pytest.mark.parametrize("model", _keypad_models())
def test_a_press_right_after_connect_reaches_the_driver(model: str) -> None:
    """A first test's trap: connect() sends the NMT start last and returns; a press at that
    same instant must come after the start has reached the keypad (it was sent first), so
    the keypad is operational and sends its key PDO (PKP §21: PDOs only when operational)."""
    with Rig() as rig:
        twin = rig.add(KeypadTwin(node_id=0x15, model=model, settings={"startup_led_show": 0}))
        keypad = Keypad.connect(rig.bus, 0x15)
        events: list[KeyEvent] = []
        keypad.keys.subscribe(events.append)
        rig.press(twin, 1)
        assert [(e.key, e.action) for e in events] == [(1, "press")]
        assert rig.snapshot(twin)["nmt_state"] == "operational"
        keypad.close()


def test_the_rig_reads_a_twin_after_what_was_sent_before() -> None:
    """rig.snapshot() after a driver call sees the device as the frames already sent left it."""
    with Rig() as rig:
        twin = rig.add(KeyboxTwin(node_id=0x0C))
        keybox = Keybox(rig.bus, 0x0C)
        assert rig.snapshot(twin)["nmt_state"] == "operational"
        keybox.close()


def test_a_frame_in_flight_when_the_bus_goes_down_is_not_delivered() -> None:
    with Rig() as rig:
        twin = rig.add(KeypadTwin(node_id=0x15, settings={"startup_led_show": 0}))
        rig.settle()
        rig.bus.send(can.Message(arbitration_id=0x000, data=[1, 0x15], is_extended_id=False))
        assert rig.network.in_flight == 1  # sent, not yet handed to the twins' endpoint
        rig.bus_down()
        rig.advance(0.01)
        assert rig.network.in_flight == 0
        rig.bus_up()
        rig.advance(0.01)
        assert twin.snapshot()["nmt_state"] == "pre-operational"  # the start never arrived
        assert [frame.can_id for _, frame in rig.frames].count(0x000) == 1  # but it was sent


def test_recv_zero_takes_a_frame_due_at_this_instant() -> None:
    """A frame sent at this virtual instant is on the wire now (latency 0): ``recv(0)``
    returns it, as python-can's virtual bus returns a queued frame, without moving the clock
    (it returned None while ``recv(>0)`` delivered it at the same time)."""
    with Rig() as rig:
        rig.add(KeyboxTwin(node_id=0x0C))  # its boot-up goes on the wire at 0.0
        message = rig.bus.recv(0)
        assert message is not None
        assert (message.arbitration_id, bytes(message.data)) == (0x70C, b"\x00")
        assert message.timestamp == 0.0
        assert rig.now == 0.0
        assert rig.bus.recv(0) is None  # nothing else is due now


def test_recv_zero_leaves_a_frame_the_wire_has_not_carried_yet() -> None:
    """With a latency the frame is genuinely not due: recv(0) is None, the clock stays, and
    the frame comes when the wire has carried it."""
    with Rig(latency=0.001) as rig:
        rig.add(KeyboxTwin(node_id=0x0C))
        assert rig.bus.recv(0) is None
        assert rig.now == 0.0
        message = rig.bus.recv(0.01)
        assert message is not None
        assert message.timestamp == pytest.approx(0.001)
