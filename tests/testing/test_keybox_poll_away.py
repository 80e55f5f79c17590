"""A Keybox driver with ``fault_poll`` on a rig whose Keybox is away (powered off, or the bus
shut down): each poll waits out its SDO timeout, longer than the poll period, and the polls
are one at a time (README: "one poll per Keybox at a time, however long the device stays
away"). In simulated time the timer, firing during a poll's wait, handed the next poll to the
pool while the first still ran, so the rig's background work never ran out and
``rig.advance(2.0)`` never returned (virtual time ran on past 50,000 s: hatk10's attack
pass). A poll on a bus that was shut down raised python-can's CanOperationError out of the
poll (logged as a traceback each period on a real bus, raised again by the rig)."""

from __future__ import annotations

import pytest

from blinkcan import Keybox
from blinkcan.testing import Rig
from blinkcan.twin import KeyboxTwin


@pytest.mark.parametrize("period", [0.05, 1.0])
def test_advance_returns_while_a_polled_keybox_is_off(rig: Rig, period: float) -> None:
    twin = rig.add(KeyboxTwin(node_id=0x0C))
    keybox = Keybox(rig.bus, 0x0C, fault_poll=period)
    keybox.on(4)
    rig.power_off(twin)
    rig.advance(2.0)  # hung here
    assert 2.0 <= rig.now < 4.0  # at most one poll's wait (timeout, retries, resync) late
    rig.power_on(twin)
    rig.advance(1.0)
    rig.blow_fuse(twin, 5)
    keybox.on(5)  # HIGH onto the blown fuse: FAULT, which the polls (and the PDO) bring in
    rig.advance(2 * period + 1.0)
    assert 5 in keybox.fault_pins
    keybox.close()


def test_polls_on_a_bus_that_was_shut_down_are_skipped(rig: Rig) -> None:
    rig.add(KeyboxTwin(node_id=0x0C))
    keybox = Keybox(rig.bus, 0x0C, fault_poll=0.05)
    rig.advance(0.2)
    rig.bus.shutdown()  # as python-canopen's network.disconnect() does
    rig.advance(1.0)  # neither hangs nor raises the polls' CanOperationError
    assert 1.2 <= rig.now < 3.0
    keybox.close()
