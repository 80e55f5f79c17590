"""Drivers by model name: the model registry (``devices/registry.py``) says which driver class
runs a model; this imports it on first use."""

from __future__ import annotations

from blinkcan.devices.registry import load_class, model


def driver_class(name: str) -> type:
    """The driver class of a model name or alias ("keypad", "pkp-2600-si@1.5")."""
    return load_class(model(name.partition("@")[0]).driver, object)
