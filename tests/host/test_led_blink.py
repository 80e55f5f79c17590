"""Blinking one colour with the Keypad driver: ``set_led(k, "blue", blink="blue")``."""

from __future__ import annotations

from blinkcan.host import Keypad
from tests.host.conftest import Rig, wait_until


def test_one_colour_blinks_on_and_off(rig: Rig) -> None:
    keypad = Keypad(rig.host)
    keypad.set_leds({1: "blue", 2: "off", 3: "red"}, blink={1: "blue", 2: "green", 3: "green"})
    wait_until(lambda: rig.emulator.snapshot(rig.keypad)["keys"][2]["alternate"])
    phases = [key["phases"] for key in rig.emulator.snapshot(rig.keypad)["keys"][:3]]
    assert phases == [["blue", "off"], ["off", "green"], ["red", "green"]]
