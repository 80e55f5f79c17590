"""The one registry of device models: names and aliases -> :class:`Model`.

As python-can's interface registry: the built-in models are ``"module:attribute"`` strings
imported on first use, and other packages add models through the ``blinkcan.models``
entry-point group (each entry point loads a :class:`Model`). Twins, drivers, scanner, decoder,
file writers, CLI and panel all look models up here. ``"keypad@1.5"`` names a generation.
"""

from __future__ import annotations

from functools import cache
from importlib import import_module
from types import MappingProxyType
from typing import TypeVar

from blinkcan.devices.model import DeviceDescription, Model
from blinkcan.devices.pdo import Direction

ENTRY_POINT_GROUP = "blinkcan.models"
#: the protocols a model may speak besides CANopen, each named by its description's features
#: (devices/keypad.py: the PKP-2600-SI's J1939 mode, spec/pkp-2600-si-j1939.md)
OTHER_PROTOCOLS = ("j1939",)
#: how a device is named: a model or alias, a generation, a protocol (emulate's /PROTOCOL;
#: other commands take it as --protocol or a j1939:ADDR node)
SPELLING = "DEVICE[@GEN][/PROTOCOL]"

#: the models blinkcan ships, in the order identity values are matched (first wins on a tie)
BUILTIN_MODELS: tuple[str, ...] = (
    "blinkcan.devices.keypad:PKP_2600_SI",
    "blinkcan.devices.keybox:KEYBOX",
    "blinkcan.devices.pkp3500:PKP_3500_MT",
    "blinkcan.devices.pkp2200:PKP_2200_SI",
    "blinkcan.devices.pkp2300:PKP_2300_SI",
    "blinkcan.devices.pkp2400:PKP_2400_SI",
    "blinkcan.devices.pkp2500:PKP_2500_SI",
    "blinkcan.devices.pkp3500si:PKP_3500_SI",
)


T = TypeVar("T")


def load(reference: str) -> object:
    """The object a ``"module:attribute"`` reference names, imported on first use: the one
    loader of the registry (models, their twin and driver classes), as python-can's interface
    registry. A reference is data, so the registry imports no layer above ``devices/``."""
    module, _, attribute = reference.partition(":")
    if not module or not attribute:
        raise ValueError(f"{reference!r} is no \"module:attribute\" reference")
    return getattr(import_module(module), attribute)


def load_class(reference: str, base: type[T]) -> type[T]:
    """The class a ``"module:Class"`` reference names; TypeError unless it is a ``base``."""
    found = load(reference)
    if not (isinstance(found, type) and issubclass(found, base)):
        raise TypeError(f"{reference} is not a {base.__name__} class")
    return found


def _load(reference: str) -> Model:
    model = load(reference)
    if not isinstance(model, Model):
        raise TypeError(f"{reference} is a {type(model).__name__}, not a blinkcan Model")
    return model


@cache
def models() -> tuple[Model, ...]:
    """Every registered model: the built-in ones first, then the entry points'."""
    from importlib.metadata import entry_points  # noqa: PLC0415 (slow, and needed once)

    found = [_load(reference) for reference in BUILTIN_MODELS]
    for entry in entry_points(group=ENTRY_POINT_GROUP):
        model = entry.load()
        if not isinstance(model, Model):
            raise TypeError(f"entry point {entry.name} ({entry.value}) is not a blinkcan Model")
        found.append(model)
    return tuple(found)


@cache
def _by_name() -> dict[str, Model]:
    return {name.lower(): model for model in reversed(models()) for name in model.names}


def model(name: str) -> Model:
    """The model called ``name`` (or one of its aliases); ValueError naming the choices."""
    try:
        return _by_name()[name.lower()]
    except (KeyError, AttributeError):
        known = ", ".join(f"{m.name} ({', '.join(m.aliases)})" if m.aliases else m.name
                          for m in models())
        raise ValueError(f"unknown device {name!r}; known: {known}; written {SPELLING}: "
                         f"{', '.join(spellings())}") from None


def model_names() -> str:
    """"pkp-2600-si (keypad; generations 1.1, 1.5), keybox, ...": every registered model, for
    help texts and error messages."""
    def one(found: Model) -> str:
        extra = [*found.aliases]
        if len(found.generations) > 1:
            extra.append(f"@{'/@'.join(found.generations)}")
        return f"{found.name} ({', '.join(extra)})" if extra else found.name

    return ", ".join(one(found) for found in models())


def spellings() -> list[str]:
    """The names with a part after the model's, as :data:`SPELLING` writes them: each
    generation of a model that has more than one ("pkp-2600-si@1.5") and each protocol a
    model speaks besides CANopen ("pkp-2600-si/j1939", read from its descriptions' features)."""
    found: list[str] = []
    for each in models():
        if len(each.generations) > 1:
            found.extend(f"{each.name}@{generation}" for generation in each.generations)
        found.extend(f"{each.name}/{protocol}" for protocol in OTHER_PROTOCOLS
                     if any(protocol in each.description(generation).features
                            for generation in each.generations))
    return found


def parse_spec(spec: str) -> tuple[Model, str]:
    """"keypad@1.5" -> (the PKP-2600-SI, "1.5"); no generation: the model's first."""
    name, _, generation = spec.partition("@")
    found = model(name)
    generation = generation or found.generations[0]
    if generation not in found.generations:
        raise ValueError(f"{found.name} generations are {', '.join(found.generations)}, "
                         f"not {generation!r}")
    return found, generation


def describe_device(spec: str, quirks: str = "firmware") -> DeviceDescription:
    """"keypad", "keybox", "keypad@1.1" -> a description (ValueError naming the choices)."""
    found, generation = parse_spec(spec)
    return found.description(generation, quirks)


@cache
def default_descriptions() -> tuple[DeviceDescription, ...]:
    """Every model at every generation, firmware profile: what identity values are matched on."""
    return tuple(m.description(g) for m in models() for g in m.generations)


def identify(device_type: int | None = None, model_id: str | None = None
             ) -> DeviceDescription | None:
    """The description whose identity matches: 100Bh (model id) decides, 1000h (device type)
    alone names the first model registered with it (two keypads share 000B0191h, MT M59)."""
    for description in default_descriptions():
        if model_id is not None and description.table["model_id"].default == model_id:
            return description
    if model_id is not None:
        return None
    for description in default_descriptions():
        if description.table["device_type"].default == device_type:
            return description
    return None


@cache
def sole_senders() -> MappingProxyType[int, DeviceDescription]:
    """PDO COB-ID base (node id added on the bus) -> the description of the one registered
    model whose frames use it, where that model transmits it (a TPDO): a frame there, at a
    node, names that node's model as identity does (decode/decoder.py learns from it). The
    model's first generation that transmits it; bases two models use name none."""
    users: dict[int, set[str]] = {}
    senders: dict[int, DeviceDescription] = {}
    for description in default_descriptions():
        for layout in description.pdos:
            users.setdefault(layout.cob_base, set()).add(description.model)
            if layout.direction is Direction.TX:
                senders.setdefault(layout.cob_base, description)
    return MappingProxyType({base: sender for base, sender in senders.items()
                             if users[base] == {sender.model}})
