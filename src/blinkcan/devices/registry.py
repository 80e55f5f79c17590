"""Device models by name: "keypad" (or "pkp-2600-si"), "keybox"; "keypad@1.1" names a
generation. A dict, so other Blink models plug in later."""

from __future__ import annotations

from collections.abc import Callable

from blinkcan.devices.keybox import describe_keybox
from blinkcan.devices.keypad import describe_keypad
from blinkcan.devices.model import DeviceDescription, Quirks, check_quirks


def _keypad(generation: str | None, quirks: Quirks) -> DeviceDescription:
    return describe_keypad(generation or "1.1", quirks)


def _keybox(generation: str | None, quirks: Quirks) -> DeviceDescription:
    if generation is not None:
        raise ValueError("the Keybox has one generation; write just 'keybox'")
    return describe_keybox(quirks)


MODELS: dict[str, Callable[[str | None, Quirks], DeviceDescription]] = {
    "keypad": _keypad,
    "pkp-2600-si": _keypad,
    "keybox": _keybox,
}


def describe_device(spec: str, quirks: str = "firmware") -> DeviceDescription:
    """"keypad", "keybox", "keypad@1.1" -> a description (ValueError naming the choices)."""
    name, _, generation = spec.lower().partition("@")
    if name not in MODELS:
        raise ValueError(f"unknown device {spec!r}; known: {', '.join(MODELS)} "
                         "(optionally @generation)")
    return MODELS[name](generation or None, check_quirks(quirks))
