"""Twins by device name: the model registry (``devices/registry.py``) says which twin class runs
a model; this imports it on first use and builds twins from specs such as ``"keypad@1.5"``."""

from __future__ import annotations

from typing import Any

from blinkcan.devices.model import Model
from blinkcan.devices.registry import load_class, model, parse_spec
from blinkcan.twin.base import CanopenTwin
from blinkcan.twin.nvm import NvmArgument


def _twin_class(found: Model) -> type[CanopenTwin]:
    return load_class(found.twin, CanopenTwin)


def twin_class(name: str) -> type[CanopenTwin]:
    """The twin class of a model name or alias ("keypad", "pkp-3500-mt@1.3")."""
    return _twin_class(model(name.partition("@")[0]))


def build_twin(spec: str, node_id: int | None = None, quirks: str = "firmware",
               nvm: NvmArgument = None, **options: Any) -> CanopenTwin:
    """A twin of ``spec`` ("keypad", "keypad@1.5", "keybox"), at its default node id unless
    one is given. ``options`` go to the twin class (``low_side`` for a Keybox)."""
    found, generation = parse_spec(spec)
    arguments: dict[str, Any] = {
        "node_id": found.default_node_id if node_id is None else node_id,
        "quirks": quirks, "nvm": nvm, "model": found.name, **options,
    }
    if len(found.generations) > 1:
        arguments["manual"] = generation
    return _twin_class(found)(**arguments)


def default_node_id(name: str) -> int:
    return model(name.partition("@")[0]).default_node_id
