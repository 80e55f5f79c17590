"""The shipped EDS files and their evidence, for every registered model and generation."""

from __future__ import annotations

import pytest

from blinkcan.devices.registry import default_descriptions
from blinkcan.formats.eds import eds_text
from blinkcan.formats.shipped import shipped_eds

DESCRIPTIONS = {f"{d.model}@{d.generation}": d for d in default_descriptions()}


@pytest.mark.parametrize("name", DESCRIPTIONS)
def test_the_shipped_eds_is_a_fresh_export_stating_the_evidence(name: str) -> None:
    description = DESCRIPTIONS[name]
    text = shipped_eds(description).read_text()
    assert text == eds_text(description)
    for line in description.evidence:  # which facts were seen, which are inferred (I-n)
        assert f"Evidence: {line}" in text
