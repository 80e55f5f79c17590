"""The python-canopen controller's tests: twins on ``rig.bus`` with the blinkcan pytest plugin.

python-canopen runs as written (``canopen.Network(rig.bus).connect()``): the rig drives its
notifier, and its SDO, NMT and heartbeat waits run in virtual time. Run with ``pytest
examples/``; ``pytest examples/ --blinkcan-record`` writes the golden trace again.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator

import pytest

from blinkcan.testing import Rig
from blinkcan.twin import KeyboxTwin, KeypadTwin
from canopen_controller import CanopenToggleController


@pytest.fixture
def controller(rig: Rig, keypad_twin: KeypadTwin, keybox_twin: KeyboxTwin
               ) -> Iterator[CanopenToggleController]:
    app = CanopenToggleController(rig.bus)
    rig.settle()
    yield app
    app.close()


def _pin(keybox: KeyboxTwin, pin: int) -> str:
    return str(keybox.snapshot()["pins"][pin - 1]["state"])


def test_it_reads_the_keybox_identity_by_sdo(controller: CanopenToggleController,
                                             keybox_twin: KeyboxTwin) -> None:
    vendor = keybox_twin.description.table.get(0x1018, 1)
    assert vendor is not None
    assert controller.vendor_id() == vendor.default


def test_a_key_toggles_its_output(rig: Rig, keypad_twin: KeypadTwin, keybox_twin: KeyboxTwin,
                                  controller: CanopenToggleController) -> None:
    rig.tap(keypad_twin, 4)
    rig.advance(0.1)
    assert _pin(keybox_twin, 4) == "high"
    rig.tap(keypad_twin, 4)
    rig.advance(0.1)
    assert _pin(keybox_twin, 4) == "off"


def test_a_blown_fuse_is_reported_and_its_output_released(
        rig: Rig, keypad_twin: KeypadTwin, keybox_twin: KeyboxTwin,
        controller: CanopenToggleController) -> None:
    rig.tap(keypad_twin, 9)
    rig.advance(0.1)
    rig.blow_fuse(keybox_twin, 9)
    rig.advance(0.1)
    assert controller.faults == {9}
    assert not controller.commanded & 1 << 8


def test_a_lost_heartbeat_is_noticed_after_three_periods(
        rig: Rig, keybox_twin: KeyboxTwin, controller: CanopenToggleController) -> None:
    assert controller.supervise()
    rig.stop_heartbeat(keybox_twin)
    start = rig.now
    assert not controller.supervise()
    assert rig.now - start == pytest.approx(0.3)  # 3 x 100 ms, virtual
    assert controller.keybox_lost


def test_outputs_come_back_after_the_keybox_power_cycles(
        rig: Rig, keypad_twin: KeypadTwin, keybox_twin: KeyboxTwin,
        controller: CanopenToggleController) -> None:
    rig.tap(keypad_twin, 2)
    rig.tap(keypad_twin, 5)
    rig.advance(0.1)
    rig.power_cycle(keybox_twin)  # boots with every output OFF, pre-operational
    rig.advance(0.1)
    assert [_pin(keybox_twin, pin) for pin in (2, 5, 6)] == ["high", "high", "off"]
    assert keybox_twin.snapshot()["nmt_state"].lower() == "operational"


def test_a_session_matches_its_golden_trace(
        rig: Rig, keypad_twin: KeypadTwin, keybox_twin: KeyboxTwin,
        controller: CanopenToggleController, golden_trace: Callable[..., None]) -> None:
    rig.tap(keypad_twin, 1)
    rig.advance(0.2)
    rig.blow_fuse(keybox_twin, 1)
    rig.advance(0.2)
    rig.power_cycle(keybox_twin)
    rig.advance(0.5)
    golden_trace(rig.frames, "traces/canopen_controller.log")
