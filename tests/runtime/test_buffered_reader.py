"""python-can's own blocking wait on a rig: ``can.BufferedReader.get_message`` on a reader a
``can.Notifier(rig.bus, [reader])`` feeds runs the simulation in virtual time, as python-canopen's
and cantools' waits do (found by hatk9: it waited in real time while the clock stood still, so
``while reader.get_message(1) is None`` hung until the plugin's wall limit)."""

from __future__ import annotations

from collections.abc import Iterator

import can
import pytest

from blinkcan.runtime.virtual_waits import LONGEST_VIRTUAL_WAIT, RECV_FOREVER, installed_waits
from blinkcan.testing import Rig
from blinkcan.twin import KeyboxTwin

HEARTBEAT_MS = 100


@pytest.fixture
def reading() -> Iterator[tuple[Rig, can.BufferedReader]]:
    """A Keybox with a 100 ms heartbeat, and a BufferedReader on the rig's bus."""
    with Rig() as rig:
        rig.add(KeyboxTwin(node_id=0x0C, settings={"producer_heartbeat_time": HEARTBEAT_MS}))
        reader = can.BufferedReader()
        notifier = can.Notifier(rig.bus, [reader])
        rig.settle()
        while reader.get_message(0) is not None:  # what came before: the boot-up
            pass
        yield rig, reader
        notifier.stop()


def test_get_message_runs_the_simulation_until_a_message_comes(
        reading: tuple[Rig, can.BufferedReader]) -> None:
    rig, reader = reading
    start = rig.now
    message = reader.get_message(1.0)
    assert message is not None
    assert message.arbitration_id == 0x70C
    assert 0 < rig.now - start <= HEARTBEAT_MS / 1000
    assert message.timestamp == rig.now


@pytest.mark.parametrize(("timeout", "waited"), [(0.05, 0.05), (None, RECV_FOREVER)])
def test_get_message_with_nothing_coming_returns_none_after_virtual_seconds(
        reading: tuple[Rig, can.BufferedReader], timeout: float | None, waited: float) -> None:
    rig, reader = reading
    rig.stop_heartbeat(0x0C)
    start = rig.now
    assert reader.get_message(timeout) is None  # type: ignore[arg-type]  # None: python-can blocks
    assert rig.now - start == pytest.approx(waited)


def test_get_message_over_the_bound_is_refused_before_the_simulation_runs(
        reading: tuple[Rig, can.BufferedReader]) -> None:
    rig, reader = reading
    start = rig.now
    with pytest.raises(ValueError, match="at most 3600 virtual seconds"):
        reader.get_message(2 * LONGEST_VIRTUAL_WAIT)
    assert rig.now == start


def test_a_reader_on_no_simulated_bus_keeps_python_cans_wait() -> None:
    with Rig() as rig:
        can.Notifier(rig.bus, [can.BufferedReader()]).stop()  # the replacement is installed
        assert "can.listener.BufferedReader.get_message" in installed_waits()
        alone = can.BufferedReader()  # no notifier feeds it: real time, as python-can waits
        assert alone.get_message(0.01) is None
    assert installed_waits() == []
