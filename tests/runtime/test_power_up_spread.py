"""Twins the emulator powers up boot out of phase, as real devices do, so their periodic
frames do not all fall due at once; in simulated time, so the schedule is exact."""

from __future__ import annotations

import pytest

from blinkcan.protocol import Frame
from blinkcan.runtime.emulator import DEFAULT_POWER_UP_SPREAD, Emulator, power_up_phase
from blinkcan.runtime.scheduler import SimulatedScheduler
from blinkcan.runtime.simbus import SimulatedBus, SimulatedNetwork
from blinkcan.testing import Rig
from blinkcan.twin import KeyboxTwin

PERIOD_MS = 10


def _keybox(node_id: int) -> KeyboxTwin:
    return KeyboxTwin(node_id=node_id, settings={
        "producer_heartbeat_time": PERIOD_MS, "fault_period": 1, "active_on_startup": 1})


def _heartbeats(frames: list[tuple[float, Frame]], node_id: int) -> list[float]:
    return [when for when, frame in frames if frame.can_id == 0x700 + node_id
            and frame.data != b"\x00"]


def test_twins_started_together_boot_at_once_and_send_out_of_phase() -> None:
    scheduler = SimulatedScheduler()
    network = SimulatedNetwork(scheduler)
    heard: list[tuple[float, Frame]] = []
    listener = SimulatedBus(network, "controller")
    detach = network.attach(lambda frame, now: heard.append((now, frame)))
    nodes = range(1, 47)
    with SimulatedBus(network, "twins") as twins, Emulator(twins, [_keybox(n) for n in nodes]):
        scheduler.run_until(None, 0.1)
    detach()
    listener.shutdown()
    boot_ups = [when for when, frame in heard if frame.data == b"\x00"
                and frame.can_id - 0x700 in nodes]
    assert boot_ups == [0.0] * len(nodes)  # every twin answers from the start
    firsts = [_heartbeats(heard, n)[0] for n in nodes]
    assert len(set(firsts)) == len(nodes)  # no two in phase
    assert min(firsts) > 0
    assert max(firsts) <= PERIOD_MS / 1000
    for n in nodes:  # each keeps its own phase, period after period
        beats = _heartbeats(heard, n)
        assert beats == pytest.approx([firsts[n - 1] + k * PERIOD_MS / 1000
                                       for k in range(len(beats))])


def test_the_phase_is_fixed_per_node_and_within_the_spread() -> None:
    phases = [power_up_phase(node, DEFAULT_POWER_UP_SPREAD) for node in range(1, 128)]
    assert all(0 <= phase < DEFAULT_POWER_UP_SPREAD for phase in phases)
    assert len(set(phases)) == len(phases)
    assert phases == [power_up_phase(node, DEFAULT_POWER_UP_SPREAD) for node in range(1, 128)]
    assert power_up_phase(5, 0.0) == 0.0


def test_without_a_spread_twins_stay_in_phase_as_in_a_rig() -> None:
    with Rig() as rig:
        first, second = rig.add(_keybox(1)), rig.add(_keybox(2))
        assert first.next_deadline() == second.next_deadline() == pytest.approx(0.01)


def test_a_spread_that_is_not_a_time_is_refused() -> None:
    scheduler = SimulatedScheduler()
    with SimulatedBus(SimulatedNetwork(scheduler), "twins") as bus:
        with pytest.raises(ValueError, match="power_up_spread"):
            Emulator(bus, [], power_up_spread=-0.01)
        with pytest.raises(ValueError, match="power_up_spread"):
            Emulator(bus, [], power_up_spread=float("nan"))
