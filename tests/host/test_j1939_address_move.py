"""Moving a J1939 keypad's source address (§16, 70h) from the driver: it follows the keypad
there, and it never says the keypad moved when nothing answers at the new address."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from blinkcan import Keypad
from blinkcan.host import NoDeviceError
from blinkcan.testing import Rig
from blinkcan.twin import KeypadTwin


@pytest.fixture
def rig() -> Iterator[Rig]:
    with Rig() as rig:
        yield rig


def test_the_driver_follows_the_keypad_to_its_new_address(rig: Rig) -> None:
    twin = rig.add(KeypadTwin(protocol="j1939"))
    keypad = Keypad(rig.bus, protocol="j1939")
    keypad.set_node_id(0x40, confirm=True)
    rig.advance(0.1)
    assert twin.j1939.address == 0x40
    keypad.set_led(1, "red")
    rig.advance(0.1)
    assert twin.snapshot()["commanded"][0]["colour"] == "red"
    assert keypad.identity().address == 0x40
    keypad.close()


def test_a_keypad_that_is_gone_is_not_said_to_have_moved(rig: Rig) -> None:
    twin = rig.add(KeypadTwin(protocol="j1939"))
    keypad = Keypad(rig.bus, protocol="j1939")
    rig.power_off(twin)
    with pytest.raises(NoDeviceError, match="40h"):
        keypad.set_node_id(0x40, confirm=True)
    keypad.close()
