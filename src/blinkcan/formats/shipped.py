"""The EDS files shipped in the package (``blinkcan/data``), one per model, firmware profile."""

from __future__ import annotations

from importlib import resources
from pathlib import Path

from blinkcan.devices.model import DeviceDescription


def shipped_eds(description: DeviceDescription) -> Path:
    """Path of the shipped EDS file of ``description``'s model and generation (its name is
    part of the description)."""
    return Path(str(resources.files("blinkcan") / "data" / description.eds_file))
