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
