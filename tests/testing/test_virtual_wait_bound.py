"""A wait on a simulated bus with a huge finite timeout ran a busy rig's simulation for ever:
``rig.bus.recv(timeout=1e308)``, python-canopen's ``wait_for_heartbeat``/``wait_for_bootup``/
``wait_for_reception`` and cantools' ``Tester.expect`` (runtime/virtual_waits.py) took any
timeout, while the drivers' event iterators and ``rig.until`` refuse one over an hour (noticed
by hfix8b). The same bound everywhere: :data:`LONGEST_VIRTUAL_WAIT`, with a ValueError naming
it, before the simulation runs."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import canopen
import pytest
from cantools import tester as cantools_tester

from blinkcan.devices.registry import describe_device
from blinkcan.formats.dbc import database
from blinkcan.formats.shipped import shipped_eds
from blinkcan.host.events import LONGEST_EVENT_WAIT
from blinkcan.runtime.virtual_waits import LONGEST_VIRTUAL_WAIT
from blinkcan.testing import Rig
from blinkcan.twin import KeyboxTwin

TOO_LONG = (1e308, LONGEST_VIRTUAL_WAIT * 2, float("nan"))


@pytest.fixture
def busy() -> Iterator[tuple[Rig, Any]]:
    """A Keybox with a 10 ms heartbeat and python-canopen watching it."""
    with Rig() as rig:
        rig.add(KeyboxTwin(node_id=0x0C, settings={"producer_heartbeat_time": 10}))
        network = canopen.Network(rig.bus)
        network.connect()
        node = network.add_node(0x0C, str(shipped_eds(describe_device("keybox"))))
        yield rig, node
        network.disconnect()


def _expect(rig: Rig, network: Any, timeout: float) -> object:
    """cantools' Tester on the rig (its own notifier: python-canopen's network let go)."""
    network.disconnect()
    make: Any = cantools_tester.Tester
    tester = make("KEYBOX_0C", database(describe_device("keybox"), node_id=0x0C), rig.bus)
    return tester.expect("KEYBOX_0C_FAULTS", timeout=timeout)


def _wait(name: str, rig: Rig, node: Any, timeout: float) -> object:
    if name == "recv":
        return rig.bus.recv(timeout)
    if name == "wait_for_heartbeat":
        return node.nmt.wait_for_heartbeat(timeout)
    if name == "wait_for_bootup":
        return node.nmt.wait_for_bootup(timeout)
    if name == "wait_for_reception":
        return node.tpdo[1].wait_for_reception(timeout)
    return _expect(rig, node.network, timeout)


@pytest.mark.parametrize("wait", ["recv", "wait_for_heartbeat", "wait_for_bootup",
                                  "wait_for_reception", "Tester.expect"])
@pytest.mark.parametrize("timeout", TOO_LONG, ids=["1e308", "two hours", "nan"])
def test_a_wait_too_long_for_a_simulated_bus_is_refused_before_it_runs(
        busy: tuple[Rig, Any], wait: str, timeout: float) -> None:
    rig, node = busy
    start = rig.now
    with pytest.raises(ValueError, match="timeout must be"):
        _wait(wait, rig, node, timeout)
    assert rig.now == start


def test_the_bound_is_the_event_iterators_and_a_wait_up_to_it_runs(
        busy: tuple[Rig, Any]) -> None:
    _, node = busy
    assert LONGEST_EVENT_WAIT == LONGEST_VIRTUAL_WAIT
    assert node.nmt.wait_for_heartbeat(LONGEST_VIRTUAL_WAIT) is not None
    with Rig() as plain:  # rig.bus read directly: no notifier takes its frames
        plain.add(KeyboxTwin(node_id=0x0C, settings={"producer_heartbeat_time": 10}))
        assert plain.bus.recv(float("inf")) is not None  # infinity waits as None does
