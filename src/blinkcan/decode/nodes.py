"""Which device is at which node, as a user says it to the decoder: an int is a CANopen node id
(``{0x15: "keypad"}``), ``"j1939:0x30"`` a J1939 source address (``{"j1939:0x30": "keypad"}``,
``--device j1939:0x30=keypad``; spec/pkp-2600-si-j1939.md §16). A J1939 address names only a
model that has a J1939 mode (its description's ``"j1939"`` feature, as ``emulate --protocol``)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import NamedTuple

from blinkcan.decode.j1939 import is_j1939_node, parse_j1939_node
from blinkcan.devices.model import DeviceDescription
from blinkcan.devices.registry import describe_device, models

#: the feature of the models that speak J1939 (devices/: their description says so)
J1939 = "j1939"

#: a device as the decoder is told it: a model name ("keypad@1.5") or a description
DeviceSpec = str | DeviceDescription
#: a node as the decoder is told it: a CANopen node id, or "j1939:ADDR"
NodeKey = int | str
#: devices by node, as callers write them (a mapping's key type is invariant: each spelled)
DevicesByNode = Mapping[int, DeviceSpec] | Mapping[str, DeviceSpec] | Mapping[NodeKey, DeviceSpec]
#: model names by node (what crosses to worker processes: plain strings)
ModelsByNode = Mapping[int, str] | Mapping[str, str] | Mapping[NodeKey, str]


class Devices(NamedTuple):
    """The devices named, by protocol: CANopen node id -> model, J1939 address -> model."""

    canopen: dict[int, DeviceDescription]
    j1939: dict[int, DeviceDescription]


def split_devices(devices: DevicesByNode | None) -> Devices:
    """The devices by protocol; ValueError naming what is wrong (an unknown model, a J1939
    address out of range, a model without J1939 at a J1939 address, a key of another type)."""
    split = Devices({}, {})
    for node, device in (devices or {}).items():
        description = device if isinstance(device, DeviceDescription) else \
            describe_device(device)
        if is_j1939_node(node):
            assert isinstance(node, str)
            address = parse_j1939_node(node)
            if J1939 not in description.features:
                having = ", ".join(m.name for m in models()
                                   if J1939 in m.description().features)
                raise ValueError(f"{node}: the {description.title} has no J1939 mode "
                                 f"(J1939: {having})")
            split.j1939[address] = description
        elif isinstance(node, int) and not isinstance(node, bool):
            split.canopen[node] = description
        else:
            raise ValueError(f"{node!r}: a node is a CANopen node id (0x15) or a J1939 "
                             "address (\"j1939:0x30\")")
    return split
