"""Device models by name: ``"keypad"`` or ``"pkp-2600-si"`` -> its twin class.

A dict, so other Blink models can be added later without touching the CLI.
"""

from __future__ import annotations

from blinkcan.twin.base import CanopenTwin
from blinkcan.twin.keybox import KeyboxTwin
from blinkcan.twin.keypad import KeypadTwin

TWIN_CLASSES: dict[str, type[CanopenTwin]] = {
    "keypad": KeypadTwin,
    "pkp-2600-si": KeypadTwin,
    "keybox": KeyboxTwin,
}
DEFAULT_NODE_IDS: dict[str, int] = {"keypad": 0x15, "pkp-2600-si": 0x15, "keybox": 0x0C}


def twin_class(name: str) -> type[CanopenTwin]:
    try:
        return TWIN_CLASSES[name.lower()]
    except KeyError:
        raise ValueError(f"unknown device {name!r}; known: {', '.join(TWIN_CLASSES)}") from None
