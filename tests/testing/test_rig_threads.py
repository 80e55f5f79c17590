"""``rig.bus.recv()`` runs the simulation, and a rig's simulation is single-threaded: a recv()
from another thread than the one that made the Rig is refused with an error that says what to
do, and the clock does not move (it ran the simulation from that thread, moving the clock
under the test's own thread: a reader thread, as on a real bus, raced the test)."""

from __future__ import annotations

import threading
from typing import Any

import can
import pytest

from blinkcan.errors import BlinkcanError
from blinkcan.testing import Rig
from blinkcan.twin import KeyboxTwin


def _in_thread(call: Any) -> Any:
    """``call()``'s result or exception, from a thread of its own."""
    outcome: list[Any] = []

    def run() -> None:
        try:
            outcome.append(call())
        except Exception as error:
            outcome.append(error)

    worker = threading.Thread(target=run, name="reader")
    worker.start()
    worker.join(10.0)
    assert not worker.is_alive()
    return outcome[0]


@pytest.mark.parametrize("timeout", [None, 0.0, 1.0])
def test_recv_from_another_thread_is_refused_and_moves_nothing(timeout: float | None) -> None:
    with Rig() as rig:
        rig.add(KeyboxTwin(node_id=0x0C, settings={"producer_heartbeat_time": 100}))
        rig.advance(0.05)
        start, sent = rig.now, len(rig.frames)
        error = _in_thread(lambda: rig.bus.recv(timeout))
        assert isinstance(error, BlinkcanError), error
        assert isinstance(error, RuntimeError)
        text = str(error)
        assert "'reader'" in text, text
        assert "'MainThread'" in text, text
        assert "can.Notifier" in text, text  # what to do instead
        assert (rig.now, len(rig.frames)) == (start, sent)
        message = rig.bus.recv(0.0)  # the boot-up, still there for the rig's own thread
        assert message is not None
        assert bytes(message.data) == b"\x00"


def test_recv_in_the_rigs_own_thread_runs_the_simulation() -> None:
    with Rig() as rig:
        rig.add(KeyboxTwin(node_id=0x0C, settings={"producer_heartbeat_time": 100}))
        boot_up = rig.bus.recv(1.0)
        assert boot_up is not None
        assert bytes(boot_up.data) == b"\x00"
        heartbeat = rig.bus.recv(1.0)
        assert heartbeat is not None
        assert bytes(heartbeat.data) == b"\x7f"
        assert rig.now == pytest.approx(0.1)


def test_a_rig_made_in_a_thread_is_that_threads() -> None:
    def made_and_used_here() -> Any:
        with Rig() as rig:
            rig.add(KeyboxTwin(node_id=0x0C))
            return rig.bus.recv(1.0)

    message = _in_thread(made_and_used_here)
    assert isinstance(message, can.Message), message


def test_a_notifier_on_the_rig_bus_still_hears_every_frame() -> None:
    with Rig() as rig:
        heard: list[int] = []
        notifier = can.Notifier(rig.bus, [lambda msg: heard.append(msg.arbitration_id)])
        rig.add(KeyboxTwin(node_id=0x0C, settings={"producer_heartbeat_time": 100}))
        rig.advance(0.25)
        notifier.stop()
        assert heard == [0x70C] * 3


SYNC = can.Message(arbitration_id=0x080, data=b"", is_extended_id=False)


def test_send_from_another_thread_is_refused_and_moves_nothing() -> None:
    """``rig.bus.send()`` from another thread wrote the wire log and the scheduler's queue
    from that thread, racing the rig's; refused as recv() is, nothing on the wire."""
    with Rig() as rig:
        rig.add(KeyboxTwin(node_id=0x0C))
        rig.advance(0.05)
        start, sent = rig.now, len(rig.frames)
        error = _in_thread(lambda: rig.bus.send(SYNC))
        assert isinstance(error, BlinkcanError), error
        assert isinstance(error, RuntimeError)
        text = str(error)
        assert "rig.bus.send()" in text, text
        assert "'reader'" in text, text
        assert "'MainThread'" in text, text
        rig.advance(0.05)
        assert len(rig.frames) == sent
        assert rig.now == pytest.approx(start + 0.05)
        rig.bus.send(SYNC)  # the rig's own thread still sends
        rig.advance(0.01)
        assert [frame.can_id for _, frame in rig.frames[sent:]] == [0x080]


def test_a_notifier_listener_and_send_periodic_still_send() -> None:
    """What the rig drives sends from the rig's thread: a listener answering a frame, a
    ``send_periodic`` task (canopen's and cantools' periodic messages)."""
    with Rig() as rig:
        class Answer(can.Listener):
            def on_message_received(self, msg: can.Message) -> None:
                if msg.arbitration_id == 0x70C:
                    rig.bus.send(SYNC)

        notifier = can.Notifier(rig.bus, [Answer()])
        task = rig.bus.send_periodic(can.Message(arbitration_id=0x123, data=b"\x01",
                                                 is_extended_id=False), 0.1)
        rig.add(KeyboxTwin(node_id=0x0C))
        rig.advance(0.25)
        task.stop()
        notifier.stop()
        ids = [frame.can_id for _, frame in rig.frames]
        assert ids.count(0x080) == 1  # the boot-up's answer
        assert ids.count(0x123) == 3
