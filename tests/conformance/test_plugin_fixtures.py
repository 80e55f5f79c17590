"""The pytest plugin's ``keypad_twin`` fixture and ``blinkcan`` marker take every registered
keypad model, generation, quirk profile and protocol (issue 20 item 10)."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from blinkcan.devices.registry import load_class
from blinkcan.testing import Rig
from blinkcan.twin import KeypadTwin
from tests.conformance.cases import CASES, Case


def _keypad_cases() -> Iterator[object]:
    for case in CASES:
        if issubclass(load_class(case.model.twin, object), KeypadTwin):
            marker = pytest.mark.blinkcan(model=case.model.name, manual=case.generation,
                                          quirks=case.quirks, protocol=case.protocol)
            yield pytest.param(case, marks=marker, id=str(case))


@pytest.mark.parametrize("case", list(_keypad_cases()))
def test_the_marker_builds_every_registered_keypad(case: Case, rig: Rig,
                                                   keypad_twin: KeypadTwin) -> None:
    rig.advance(0.1)
    snapshot = keypad_twin.snapshot()
    assert (snapshot["model"], snapshot["generation"], snapshot["quirks"],
            snapshot["protocol"]) == (case.model.name, case.generation, case.quirks,
                                      case.protocol)


@pytest.mark.parametrize("fixture", ["rig", "keypad_twin", "keybox_twin", "golden_trace"])
def test_every_fixture_has_a_docstring(fixture: str) -> None:
    from blinkcan.testing import plugin

    assert getattr(plugin, fixture).__doc__, fixture
