"""A keypad in J1939 mode answers no SDO (spec/pkp-2600-si-j1939.md): reading one of its
CANopen objects is refused at once, naming the mode, instead of an SDO request to a node id
the keypad does not have, timing out (found by the newcomer/attacker pass of session 4; the
command line refuses `read` over J1939 before the bus opens)."""

from __future__ import annotations

import pytest

from blinkcan import Keypad
from blinkcan.testing import Rig
from blinkcan.twin import KeypadTwin


def test_the_driver_refuses_an_sdo_read_in_j1939_mode() -> None:
    with Rig() as rig:
        rig.add(KeypadTwin(protocol="j1939"))
        keypad = Keypad(rig.bus, protocol="j1939", address=0x21)
        rig.settle()
        before = len(rig.frames)
        with pytest.raises(ValueError, match="J1939 mode"):
            keypad.read("producer_heartbeat_time")
        rig.settle()
        assert not [f for f in rig.frames[before:] if not f.frame.extended]  # no SDO sent
        keypad.close()
