"""``Keypad.connect(bus, protocol="j1939", address=...)`` drives a keypad in J1939 mode (found
by the attack pass of session 7: it read 100Bh over SDO at node 15h whatever the protocol, and
raised "no device answers at node 15h" with the J1939 keypad right there)."""

from __future__ import annotations

import re
from typing import Any

import pytest

from blinkcan import Keypad
from blinkcan.host import NoDeviceError
from blinkcan.host.j1939_keypad import J1939Identity, j1939_models
from blinkcan.testing import Rig
from blinkcan.twin.registry import build_twin


@pytest.mark.parametrize("name", j1939_models())
def test_connect_drives_a_keypad_in_j1939_mode(name: str) -> None:
    with Rig() as rig:
        twin = rig.add(build_twin(name, node_id=0x15, protocol="j1939",
                                  settings={"j1939_source_address": 0x30}))
        keypad = Keypad.connect(rig.bus, protocol="j1939", address=0x30)
        identity = keypad.identity()
        assert isinstance(identity, J1939Identity)
        assert (identity.address, identity.model) == (0x30, name)
        keypad.set_led(2, "green")
        assert rig.snapshot(twin)["commanded"][1]["colour"] == "green"  # key 2
        keypad.close()


def test_connect_in_j1939_mode_says_when_no_keypad_is_heard() -> None:
    with Rig() as rig, pytest.raises(NoDeviceError, match=r"^no keypad heard at 30h$"):
        Keypad.connect(rig.bus, protocol="j1939", address=0x30)


# -- times given to a driver are checked before anything is sent (same attack pass: a negative
# sdo_timeout went out as a read and came back as "no reply within -1 s", a NaN long_press was
# taken, and no long press was ever reported) ---------------------------------------------------

@pytest.mark.parametrize(("options", "said"), [
    ({"sdo_timeout": -1}, "sdo_timeout must be >= 0 seconds, not -1"),
    ({"sdo_timeout": float("nan")}, "sdo_timeout must be a finite number of seconds, not nan"),
    ({"long_press": float("nan")}, "long_press must be a finite number of seconds, not nan"),
    ({"long_press": -0.5}, "long_press must be >= 0 seconds, not -0.5"),
])
@pytest.mark.parametrize("make", [Keypad, Keypad.connect])
def test_a_drivers_times_are_checked_before_anything_is_sent(
        make: Any, options: dict[str, float], said: str) -> None:
    with Rig() as rig:
        rig.add(build_twin("keypad", node_id=0x15))
        rig.settle()
        sent = len(rig.frames)
        with pytest.raises(ValueError, match=f"^{re.escape(said)}$"):
            make(rig.bus, 0x15, **options)
        rig.settle()
        assert len(rig.frames) == sent
