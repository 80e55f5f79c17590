"""The EDS files shipped in the package (``blinkcan/data``), one per model, firmware profile."""

from __future__ import annotations

from importlib import resources
from pathlib import Path

from blinkcan.devices.model import DeviceDescription

#: the generation each model's plain file describes; others get "-rev<generation>" in the name
_FIRST = {"pkp-2600-si": "1.1"}


def shipped_eds(description: DeviceDescription) -> Path:
    """Path of the shipped EDS file of ``description``'s model and generation."""
    name = description.model
    if _FIRST.get(description.model, description.generation) != description.generation:
        name += f"-rev{description.generation}"
    return Path(str(resources.files("blinkcan") / "data" / f"{name}.eds"))
