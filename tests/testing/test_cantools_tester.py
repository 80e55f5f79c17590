"""cantools' ``Tester`` on ``rig.bus`` (issue 24): its notifier is driven by the rig and
``expect`` waits in virtual time, with our DBC."""

from __future__ import annotations

from typing import Any

import can
import pytest
from cantools import tester as cantools_tester

from blinkcan.devices.registry import describe_device
from blinkcan.formats.dbc import database
from blinkcan.testing import Rig
from blinkcan.twin import KeyboxTwin


def _tester(rig: Rig) -> Any:
    """A Tester with the Keybox as the device under test (cantools is untyped: Any)."""
    make: Any = cantools_tester.Tester
    return make("KEYBOX_0C", database(describe_device("keybox"), node_id=0x0C), rig.bus)


def test_expect_times_out_after_its_timeout_in_virtual_time() -> None:
    """Was: expect() waited on the wall clock while the notifier's thread ran the simulation
    ahead on its own."""
    with Rig() as rig:
        rig.add(KeyboxTwin(node_id=0x0C))  # no output on: no fault PDO to expect
        tester = _tester(rig)
        assert tester.expect("KEYBOX_0C_FAULTS", timeout=0.75) is None
        assert rig.now == pytest.approx(0.75)


def test_expect_returns_the_message_when_it_comes_and_keeps_the_others() -> None:
    with Rig() as rig:
        twin = rig.add(KeyboxTwin(node_id=0x0C, settings={"producer_heartbeat_time": 100}))
        tester = _tester(rig)
        rig.bus.send(can.Message(arbitration_id=0, data=[1, 0x0C], is_extended_id=False))
        assert tester.expect("KEYBOX_0C_HEARTBEAT", {"state": "operational"},
                             timeout=1.0) == {"state": "operational"}
        assert rig.now == pytest.approx(0.1)
        tester.send("KEYBOX_0C_OUTPUTS", {"high_2": 1})
        rig.advance(0.01)
        rig.blow_fuse(twin, 2)
        faults = tester.expect("KEYBOX_0C_FAULTS", timeout=1.0, discard_other_messages=False)
        assert faults is not None
        assert faults["faults_2"] == 1
        assert rig.now == pytest.approx(0.11)
        assert tester.expect("KEYBOX_0C_HEARTBEAT", timeout=0.5) is not None  # kept


def test_expect_without_a_timeout_gives_up_after_a_virtual_minute() -> None:
    with Rig() as rig:
        tester = _tester(rig)
        assert tester.expect("KEYBOX_0C_FAULTS") is None
        assert rig.now == pytest.approx(60.0)
