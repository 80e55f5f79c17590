"""Drivers by model name: the model registry (``devices/registry.py``) says which driver class
runs a model; this imports it on first use."""

from __future__ import annotations

from importlib import import_module

from blinkcan.devices.registry import model


def driver_class(name: str) -> type:
    """The driver class of a model name or alias ("keypad", "pkp-2600-si@1.5")."""
    found = model(name.partition("@")[0])
    module, _, attribute = found.driver.partition(":")
    return getattr(import_module(module), attribute)  # type: ignore[no-any-return]
