"""The pytest plugin's fixtures and marker, as a user's test sees them."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import pytest

from blinkcan import Keypad
from blinkcan.testing import Rig, record_trace
from blinkcan.twin import KeyboxTwin, KeypadTwin


def test_fixtures_give_twins_on_a_rig(rig: Rig, keypad_twin: KeypadTwin,
                                      keybox_twin: KeyboxTwin) -> None:
    assert rig.now == 0.0
    assert keypad_twin.snapshot()["startup_show"] is None  # off unless the marker asks for it
    assert (keypad_twin.node_id, keybox_twin.node_id) == (0x15, 0x0C)
    assert keypad_twin.snapshot()["generation"] == "1.1"


@pytest.mark.blinkcan(manual="1.5", quirks="cia301", keypad_node=0x16, startup_show=True)
def test_the_marker_chooses_the_twins(keypad_twin: KeypadTwin) -> None:
    snapshot = keypad_twin.snapshot()
    assert (snapshot["generation"], snapshot["quirks"], keypad_twin.node_id) == (
        "1.5", "cia301", 0x16)
    assert snapshot["startup_show"] is not None


def test_golden_trace_fixture_compares_with_a_recorded_trace(
        rig: Rig, keypad_twin: KeypadTwin, golden_trace: Callable[..., None],
        tmp_path: Path) -> None:
    keypad = Keypad(rig.bus, 0x15)
    rig.tap(keypad_twin, 1)
    rig.advance(0.5)
    keypad.close()
    trace = tmp_path / "tap.log"
    record_trace(rig.frames, trace)
    golden_trace(rig.frames, str(trace))  # an absolute path is taken as it is
    with pytest.raises(AssertionError):
        golden_trace(rig.frames[1:], str(trace))
    with pytest.raises(AssertionError, match="--blinkcan-record"):
        golden_trace(rig.frames, str(tmp_path / "never-recorded.log"))
