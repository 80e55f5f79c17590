"""A plain python-can controller on the rig (issue 24): a ``can.Notifier`` on ``rig.bus`` is
driven by the simulation (its listeners hear every frame at its virtual time, in order, in the
test's thread), and ``send_periodic`` runs on the virtual clock."""

from __future__ import annotations

import asyncio
import threading
import time

import can
import pytest

from blinkcan.protocol.cob import HEARTBEAT
from blinkcan.testing import Rig
from blinkcan.twin import KeyboxTwin

FAST_HEARTBEAT = {"producer_heartbeat_time": 100}


def _heard(rig: Rig, seconds: float) -> list[tuple[float, int, bytes, str]]:
    heard: list[tuple[float, int, bytes, str]] = []
    notifier = can.Notifier(rig.bus, [lambda msg: heard.append(
        (msg.timestamp, msg.arbitration_id, bytes(msg.data), threading.current_thread().name))])
    rig.advance(seconds)
    notifier.stop()
    return heard


def test_a_notifier_hears_every_frame_at_its_virtual_time_in_the_tests_thread() -> None:
    with Rig() as rig:
        rig.add(KeyboxTwin(node_id=0x0C, settings=FAST_HEARTBEAT))
        rig.settle()
        heard = _heard(rig, 1.0)
    heartbeats = [(when, data) for when, can_id, data, _ in heard if can_id == HEARTBEAT + 0x0C]
    assert [when for when, _ in heartbeats] == pytest.approx([0.1 * i for i in range(1, 11)])
    assert {thread for *_, thread in heard} == {threading.current_thread().name}


def test_a_notifier_thread_never_runs_the_simulation() -> None:
    """Was: the notifier's thread called recv(1.0), which ran the simulation from that thread
    (virtual time raced ahead of the test while it did nothing)."""
    with Rig() as rig:
        rig.add(KeyboxTwin(node_id=0x0C, settings=FAST_HEARTBEAT))
        heard: list[can.Message] = []
        notifier = can.Notifier(rig.bus, [heard.append])
        time.sleep(0.05)  # wall time: the notifier's thread is running meanwhile
        assert rig.now == 0.0
        assert heard == []
        notifier.stop()
        assert not any(reader.is_alive() for reader in notifier._readers
                       if isinstance(reader, threading.Thread))


def test_two_runs_hear_the_same_frames_at_the_same_times() -> None:
    def run() -> list[tuple[float, int, bytes]]:
        with Rig() as rig:
            rig.add(KeyboxTwin(node_id=0x0C, settings=FAST_HEARTBEAT))
            return [(when, can_id, data) for when, can_id, data, _ in _heard(rig, 2.0)]

    first = run()
    assert first
    assert run() == first


def test_a_listener_that_raises_fails_the_call_that_ran_the_simulation() -> None:
    def broken(msg: can.Message) -> None:
        raise RuntimeError(f"listener saw {msg.arbitration_id:03X}h")

    with Rig() as rig:
        rig.add(KeyboxTwin(node_id=0x0C, settings=FAST_HEARTBEAT))
        rig.settle()
        notifier = can.Notifier(rig.bus, [broken])
        with pytest.raises(RuntimeError, match="listener saw 70Ch"):
            rig.advance(0.2)
        notifier.stop()


def test_closing_the_rig_stops_a_notifier_left_reading_its_bus() -> None:
    rig = Rig()
    notifier = can.Notifier(rig.bus, [lambda msg: None])
    rig.close()
    assert notifier.stopped
    assert not any(reader.is_alive() for reader in notifier._readers
                   if isinstance(reader, threading.Thread))


def test_a_notifier_with_an_asyncio_loop_is_refused() -> None:
    loop = asyncio.new_event_loop()
    try:
        with Rig() as rig:
            with pytest.raises(ValueError, match="asyncio loop"):
                can.Notifier(rig.bus, [lambda msg: None], loop=loop)
            assert can.Notifier.find_instances(rig.bus) == ()  # and the bus stays free
            can.Notifier(rig.bus, [lambda msg: None]).stop()
    finally:
        loop.close()


def test_recv_still_works_once_the_notifier_stopped() -> None:
    with Rig() as rig:
        rig.add(KeyboxTwin(node_id=0x0C, settings=FAST_HEARTBEAT))
        rig.settle()
        rig.bus.clear_received()
        can.Notifier(rig.bus, [lambda msg: None]).stop()
        message = rig.bus.recv(1.0)
        assert message is not None
        assert message.arbitration_id == HEARTBEAT + 0x0C
        assert message.timestamp == pytest.approx(0.1)


def test_send_periodic_runs_on_the_virtual_clock() -> None:
    with Rig() as rig:
        message = can.Message(arbitration_id=0x123, data=[1], is_extended_id=False)
        task = rig.bus.send_periodic(message, 0.25)
        rig.advance(1.0)
        assert isinstance(task, can.ModifiableCyclicTaskABC)
        task.modify_data(can.Message(arbitration_id=0x123, data=[2], is_extended_id=False))
        rig.advance(0.5)
        task.stop()
        rig.advance(1.0)
        sent = [(when, frame.data) for when, frame in rig.frames if frame.can_id == 0x123]
    assert sent == [(0.0, b"\x01"), (0.25, b"\x01"), (0.5, b"\x01"), (0.75, b"\x01"),
                    (1.0, b"\x01"), (1.25, b"\x02"), (1.5, b"\x02")]


def test_send_periodic_with_a_duration_stops_by_itself_and_on_a_bus_that_went_down() -> None:
    with Rig() as rig:
        rig.bus.send_periodic(can.Message(arbitration_id=0x124, data=[1]), 0.1, duration=0.3)
        rig.bus.send_periodic(can.Message(arbitration_id=0x125, data=[1]), 0.1)
        rig.advance(0.45)
        rig.bus_down()
        rig.advance(0.1)  # the send fails: the task stops, as python-can's thread does
        rig.bus_up()
        rig.advance(1.0)
        times = {can_id: [when for when, frame in rig.frames if frame.can_id == can_id]
                 for can_id in (0x124, 0x125)}
    assert times[0x124] == pytest.approx([0.0, 0.1, 0.2])
    assert times[0x125] == pytest.approx([0.0, 0.1, 0.2, 0.3, 0.4])
