"""The one registry of models: names, aliases, generations, entry points; every layer reads it."""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import replace
from typing import Any

import pytest

from blinkcan.devices import registry
from blinkcan.devices.keypad import PKP_2600_SI, describe_keypad
from blinkcan.devices.registry import describe_device, identify, model, parse_spec
from blinkcan.twin import KeyboxTwin, KeypadTwin
from blinkcan.twin.pkp3500 import Pkp3500Twin
from blinkcan.twin.registry import build_twin, twin_class


@pytest.fixture
def clean_registry() -> Iterator[None]:
    registry.models.cache_clear()
    registry._by_name.cache_clear()
    registry.default_descriptions.cache_clear()
    yield
    registry.models.cache_clear()
    registry._by_name.cache_clear()
    registry.default_descriptions.cache_clear()


def test_names_and_aliases_name_one_model() -> None:
    assert model("keypad") is model("PKP-2600-SI") is PKP_2600_SI
    assert parse_spec("keypad@1.5") == (PKP_2600_SI, "1.5")
    assert parse_spec("keybox")[1] == "1.0"


def test_the_twin_registry_and_the_description_registry_agree() -> None:
    # the two registries once disagreed: "emulate keypad@1.5" was an unknown device
    twin = build_twin("keypad@1.5")
    assert isinstance(twin, KeypadTwin)
    assert (twin.node_id, twin.description.generation) == (0x15, "1.5")
    assert twin.description == describe_device("keypad@1.5")
    assert isinstance(build_twin("keybox", 0x0D, low_side=(2,)), KeyboxTwin)
    assert twin_class("pkp-2600-si@1.1") is KeypadTwin


def test_emulate_takes_a_generation() -> None:
    from blinkcan.cli.emulate import build_twins

    (twin,) = build_twins(("keypad@1.5:0x16",), None, None, "firmware")
    assert (twin.node_id, twin.description.generation) == (0x16, "1.5")


def test_identity_values_name_the_model() -> None:
    found = identify(device_type=0x000B0191)
    assert found is not None
    assert found.model == "pkp-2600-si"
    found = identify(model_id="Keybox3")
    assert found is not None
    assert found.model == "keybox"
    assert identify(model_id="Toaster", device_type=0x000B0191) is None
    assert identify(device_type=0x12345678) is None


def test_other_packages_add_models_through_the_entry_point_group(
        monkeypatch: pytest.MonkeyPatch, clean_registry: None) -> None:
    import importlib.metadata

    twelve = replace(PKP_2600_SI, name="pkp-2612-xx", aliases=("xx",))

    class Entry:
        name, value = "pkp-2612-xx", "somewhere:MODEL"

        def load(self) -> Any:
            return twelve

    def entry_points(group: str) -> list[Entry]:
        return [Entry()] if group == registry.ENTRY_POINT_GROUP else []

    monkeypatch.setattr(importlib.metadata, "entry_points", entry_points)
    assert model("xx") is twelve
    names = [m.name for m in registry.models()]
    assert names[:2] == ["pkp-2600-si", "keybox"]  # the built-in models first, in order
    assert names[-1] == "pkp-2612-xx"
    assert len(names) == len(registry.BUILTIN_MODELS) + 1


def test_an_entry_point_that_is_not_a_model_is_refused(
        monkeypatch: pytest.MonkeyPatch, clean_registry: None) -> None:
    import importlib.metadata

    class Entry:
        name, value = "bad", "somewhere:THING"

        def load(self) -> Any:
            return object()

    monkeypatch.setattr(importlib.metadata, "entry_points", lambda group: [Entry()])
    with pytest.raises(TypeError, match="not a blinkcan Model"):
        registry.models()


def test_keypad_twin_refuses_a_model_that_is_not_a_keypad() -> None:
    with pytest.raises(ValueError, match="not a keypad"):
        KeypadTwin(model="keybox")
    with pytest.raises(ValueError, match="unknown device"):
        KeypadTwin(model="toaster")
    with pytest.raises(ValueError, match="pkp-2600-si runs on"):
        Pkp3500Twin(model="pkp-2600-si")  # never half a twin


def test_a_keypad_that_behaves_as_the_pkp_2600_si_needs_only_its_description(
        monkeypatch: pytest.MonkeyPatch, clean_registry: None) -> None:
    # issue 19: a fourth keypad is its description plus a registry entry naming KeypadTwin
    import importlib.metadata

    def describe(generation: str, quirks: Any, node_id: int) -> Any:
        return replace(describe_keypad(generation, quirks, node_id), model="pkp-2612-xx")

    twelve = replace(PKP_2600_SI, name="pkp-2612-xx", aliases=("xx",), describe=describe)

    class Entry:
        name, value = "pkp-2612-xx", "somewhere:MODEL"

        def load(self) -> Any:
            return twelve

    monkeypatch.setattr(importlib.metadata, "entry_points",
                        lambda group: [Entry()] if group == registry.ENTRY_POINT_GROUP else [])
    twin = KeypadTwin(node_id=0x16, model="xx", manual="1.5")
    assert type(twin) is KeypadTwin
    assert (twin.description.model, twin.description.generation) == ("pkp-2612-xx", "1.5")
    assert twin.power_on(0.0)[0].can_id == 0x716  # boot-up at its node id
    assert twin.snapshot()["model"] == "pkp-2612-xx"
