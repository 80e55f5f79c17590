"""The cantools controller's tests: twins on ``rig.bus`` with the blinkcan pytest plugin.

The controller's ``can.Notifier`` on ``rig.bus`` is driven by the rig, in the test's thread and
in virtual time; its clock is the rig's. Run with ``pytest examples/``; ``pytest examples/
--blinkcan-record`` writes the golden trace again.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator

import pytest

from blinkcan.testing import Rig
from blinkcan.twin import KeyboxTwin, KeypadTwin
from cantools_controller import CantoolsToggleController


@pytest.fixture
def controller(rig: Rig, keypad_twin: KeypadTwin, keybox_twin: KeyboxTwin
               ) -> Iterator[CantoolsToggleController]:
    app = CantoolsToggleController(rig.bus, clock=lambda: rig.now)
    rig.settle()
    yield app
    app.close()


def _pin(keybox: KeyboxTwin, pin: int) -> str:
    return str(keybox.snapshot()["pins"][pin - 1]["state"])


def _led(keypad: KeypadTwin, key: int) -> str:
    return str(keypad.snapshot()["commanded"][key - 1]["colour"])


def test_a_key_toggles_its_output_and_led(rig: Rig, keypad_twin: KeypadTwin,
                                          keybox_twin: KeyboxTwin,
                                          controller: CantoolsToggleController) -> None:
    rig.tap(keypad_twin, 4)
    rig.advance(0.1)
    assert (_pin(keybox_twin, 4), _led(keypad_twin, 4)) == ("high", "green")
    rig.tap(keypad_twin, 4)
    rig.advance(0.1)
    assert (_pin(keybox_twin, 4), _led(keypad_twin, 4)) == ("off", "off")


def test_a_blown_fuse_turns_its_led_red(rig: Rig, keypad_twin: KeypadTwin,
                                        keybox_twin: KeyboxTwin,
                                        controller: CantoolsToggleController) -> None:
    rig.tap(keypad_twin, 7)
    rig.advance(0.1)
    rig.blow_fuse(keybox_twin, 7)
    rig.advance(0.1)
    assert controller.faults == {7}
    assert _led(keypad_twin, 7) == "red"


def test_a_lost_heartbeat_is_noticed_after_three_periods(
        rig: Rig, keybox_twin: KeyboxTwin, controller: CantoolsToggleController) -> None:
    rig.advance(0.5)
    assert controller.keybox_alive()
    rig.stop_heartbeat(keybox_twin)
    rig.advance(0.3)
    assert controller.keybox_alive()  # the last one came 0.3 s ago: still in time
    rig.advance(0.05)
    assert not controller.keybox_alive()


def test_outputs_come_back_after_the_keybox_power_cycles(
        rig: Rig, keypad_twin: KeypadTwin, keybox_twin: KeyboxTwin,
        controller: CantoolsToggleController) -> None:
    rig.tap(keypad_twin, 3)
    rig.advance(0.1)
    rig.power_cycle(keybox_twin)
    rig.advance(0.1)
    assert _pin(keybox_twin, 3) == "high"
    assert _led(keypad_twin, 3) == "green"


def test_a_session_matches_its_golden_trace(
        rig: Rig, keypad_twin: KeypadTwin, keybox_twin: KeyboxTwin,
        controller: CantoolsToggleController, golden_trace: Callable[..., None]) -> None:
    rig.tap(keypad_twin, 1)
    rig.advance(0.2)
    rig.blow_fuse(keybox_twin, 1)
    rig.advance(0.2)
    rig.power_cycle(keybox_twin)
    rig.advance(0.5)
    golden_trace(rig.frames, "traces/cantools_controller.log")
