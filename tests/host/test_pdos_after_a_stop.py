"""What a keypad driver sends by PDO while the keypad ignores PDOs (CiA 301: RPDOs are acted on
only in OPERATIONAL) is shown once the keypad is started again: an NMT stop or pre-operational
by this driver or by another master, then a start. The driver re-sends its picture (LEDs, ring
LEDs, indicator and backlight levels) after the start, as it does after a reboot; before,
``set_led`` returned and the key stayed dark for good (found by the attack pass of session 8).
Over every registered keypad model and generation."""

from __future__ import annotations

from typing import Any

import pytest

from blinkcan import Keypad
from blinkcan.host.pkp3500 import Pkp3500Keypad
from blinkcan.protocol import Frame
from blinkcan.protocol.nmt import NmtCommand
from blinkcan.testing import Rig
from blinkcan.twin.registry import build_twin
from tests.conformance.cases import CASES, Case

KEYPADS = [case for case in CASES
           if case.canopen and case.quirks == "firmware" and case.description.face.led_keys]


def _lit(rig: Rig, twin: Any, key: int) -> str:
    return str(rig.snapshot(twin)["keys"][key - 1]["colour"])


@pytest.mark.parametrize("case", KEYPADS, ids=str)
@pytest.mark.parametrize("who", ["driver", "another master"])
@pytest.mark.parametrize("pause", [NmtCommand.STOP, NmtCommand.ENTER_PRE_OPERATIONAL],
                         ids=["stop", "pre-operational"])
def test_leds_set_while_pdos_were_ignored_are_shown_after_the_start(
        case: Case, who: str, pause: NmtCommand) -> None:
    face = case.description.face
    first, second = face.led_keys[0], face.led_keys[-1]
    with Rig() as rig:
        twin = rig.add(build_twin(case.spec, quirks=case.quirks,
                                  settings={"startup_led_show": 0}))
        keypad = Keypad(rig.bus, 0x15, model=case.model.name)
        keypad.set_led(first, "green")

        def command(nmt: NmtCommand) -> None:
            if who == "driver":
                keypad.nmt(nmt)
            else:  # a frame on the wire that the driver's bus did not send
                rig.act(lambda now: [Frame(0x000, bytes((int(nmt), 0x15)))])
            rig.advance(0.2)

        command(pause)
        keypad.set_led(second, "red")  # the keypad ignores this PDO
        keypad.set_led(first, "off")
        rig.advance(0.2)
        assert _lit(rig, twin, second) == "off"
        command(NmtCommand.START)
        assert (_lit(rig, twin, first), _lit(rig, twin, second)) == ("off", "red")
        keypad.close()


@pytest.mark.parametrize("case", [case for case in KEYPADS if case.description.face.encoders],
                         ids=str)
def test_ring_leds_set_while_stopped_are_shown_after_the_start(case: Case) -> None:
    with Rig() as rig:
        rig.add(build_twin(case.spec, quirks=case.quirks,
                                  settings={"startup_led_show": 0}))
        keypad = Keypad(rig.bus, 0x15, model=case.model.name)
        assert isinstance(keypad, Pkp3500Keypad)
        keypad.stop()
        rig.advance(0.2)
        keypad.set_ring(1, [1, 2, 3])
        keypad.start()
        rig.advance(0.2)
        assert keypad.read_rings() == [1, 2, 3]  # what the keypad shows (SDO 2000h, MT §20c)
        keypad.close()


@pytest.mark.parametrize("case", KEYPADS, ids=str)
def test_a_driver_that_sent_nothing_meanwhile_sends_nothing_after_the_start(case: Case) -> None:
    """What another program lit stays lit: a driver (``blinkcan keypad led``: start=False,
    then a start, then the LEDs read) re-sends nothing it did not send while PDOs were
    ignored (its empty picture would switch every LED off)."""
    key = case.description.face.led_keys[0]
    with Rig() as rig:
        twin = rig.add(build_twin(case.spec, quirks=case.quirks,
                                  settings={"startup_led_show": 0}))
        Keypad(rig.bus, 0x15, model=case.model.name).set_led(key, "blue")
        pre_operational = Frame(0x000, bytes((int(NmtCommand.ENTER_PRE_OPERATIONAL), 0x15)))
        rig.act(lambda now: [pre_operational])  # SDO still answered: the driver confirms
        rig.advance(0.2)
        other = Keypad(rig.bus, 0x15, model=case.model.name, start=False)
        other.start()
        rig.advance(0.2)
        assert _lit(rig, twin, key) == "blue"
        other.close()
