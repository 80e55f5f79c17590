"""The toggle controller's tests: twins on a simulated bus, with the blinkcan pytest plugin.

Run with ``pytest examples/``. Every test runs in virtual time: the watchdog test covers half a
second of the devices' life and takes a few milliseconds.
"""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from blinkcan.testing import Rig
from blinkcan.twin import KeyboxTwin, KeypadTwin
from toggle_controller import ToggleController


@pytest.fixture
def controller(rig: Rig, keypad_twin: KeypadTwin, keybox_twin: KeyboxTwin
               ) -> Iterator[ToggleController]:
    app = ToggleController(rig.bus)
    rig.settle()
    yield app
    app.close()


def test_key_toggles_its_output_and_led(rig: Rig, keypad_twin: KeypadTwin,
                                        keybox_twin: KeyboxTwin,
                                        controller: ToggleController) -> None:
    rig.tap(keypad_twin, 4)
    rig.advance(0.1)
    assert keybox_twin.snapshot()["pins"][3]["state"] == "high"
    assert keypad_twin.snapshot()["commanded"][3]["colour"] == "green"
    rig.tap(keypad_twin, 4)
    rig.advance(0.1)
    assert keybox_twin.snapshot()["pins"][3]["state"] == "off"
    assert keypad_twin.snapshot()["commanded"][3]["colour"] == "off"


def test_a_fault_blinks_the_key_red_and_a_press_resets_it(
        rig: Rig, keypad_twin: KeypadTwin, keybox_twin: KeyboxTwin,
        controller: ToggleController) -> None:
    rig.tap(keypad_twin, 7)
    rig.advance(0.1)
    rig.blow_fuse(keybox_twin, 7)
    rig.advance(0.1)
    assert keypad_twin.snapshot()["commanded"][6]["phases"] == ["red", "off"]  # blinking red
    rig.replace_fuse(keybox_twin, 7)
    rig.tap(keypad_twin, 7)
    rig.advance(0.1)
    assert keybox_twin.snapshot()["pins"][6]["state"] == "off"


def test_outputs_go_off_when_the_controller_dies(
        rig: Rig, keypad_twin: KeypadTwin, keybox_twin: KeyboxTwin,
        controller: ToggleController) -> None:
    rig.tap(keypad_twin, 2)
    rig.advance(0.5)
    assert keybox_twin.snapshot()["pins"][1]["state"] == "high"  # the heartbeat keeps it on
    controller.keybox.stop_host_heartbeat()  # as a crashed controller would
    rig.advance(0.25)
    assert keybox_twin.snapshot()["pins"][1]["state"] == "off"  # the Keybox's watchdog tripped
    rig.advance(1.0)
    assert keybox_twin.snapshot()["pins"][1]["state"] == "off"  # and nothing switched it back


def test_leds_follow_the_keybox_when_it_power_cycles(
        rig: Rig, keypad_twin: KeypadTwin, keybox_twin: KeyboxTwin,
        controller: ToggleController) -> None:
    """Issue 17: key 4 stayed green after the Keybox rebooted with output 4 off."""
    rig.tap(keypad_twin, 4)
    rig.tap(keypad_twin, 6)
    rig.advance(0.1)
    assert keybox_twin.snapshot()["pins"][3]["state"] == "high"
    rig.power_cycle(keybox_twin)  # a brown-out: every output OFF after the reboot
    rig.advance(0.5)
    pins, leds = keybox_twin.snapshot()["pins"], keypad_twin.snapshot()["commanded"]
    assert [pins[i]["state"] for i in (3, 5)] == ["off", "off"]
    assert [leds[i]["colour"] for i in (3, 5)] == ["off", "off"]
    rig.tap(keypad_twin, 4)  # one press switches it on again, as the LED promised
    rig.advance(0.1)
    assert keybox_twin.snapshot()["pins"][3]["state"] == "high"
    assert keypad_twin.snapshot()["commanded"][3]["colour"] == "green"
