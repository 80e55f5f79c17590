"""PDOs with python-canopen, configured from our EDS (issue 17 item 10): a ``RemoteNode``
reads every PDO configuration of the twin (``tpdo.read()``, ``rpdo.read()``), and a frame of the
length the EDS maps is one the device and the drivers take."""

from __future__ import annotations

import io
from typing import Any

import canopen
import pytest

from blinkcan.devices.model import QUIRK_PROFILES, DeviceDescription
from blinkcan.devices.objects import NodeIdRelative
from blinkcan.devices.registry import describe_device, models
from blinkcan.formats.canopen_od import object_dictionary
from blinkcan.formats.eds import eds_text
from blinkcan.testing import Rig
from blinkcan.twin.registry import build_twin

#: every registered model, generation and quirk profile: "model@generation:quirks"
DEVICES = [f"{model.name}@{generation}:{quirks}" for model in models()
           for generation in model.generations for quirks in QUIRK_PROFILES]


def _eds(description: DeviceDescription) -> io.StringIO:
    text = io.StringIO(eds_text(description))
    text.name = "exported.eds"  # python-canopen tells the format by the name
    return text


@pytest.mark.parametrize("device", DEVICES)
def test_a_remote_node_from_the_eds_reads_every_pdo_configuration(device: str) -> None:
    spec, _, quirks = device.partition(":")
    twin = build_twin(spec, quirks=quirks)
    description = twin.description
    with Rig() as rig:
        rig.add(twin)
        network: Any = canopen.Network(rig.bus)
        network.connect()
        try:
            node: Any = canopen.RemoteNode(twin.node_id, _eds(description))
            network.add_node(node)
            node.tpdo.read()  # PKP-3500-MT: aborted 0602 0000h on 1A03h
            node.rpdo.read()
            cob_ids = {pdo.cob_id for pdos in (node.tpdo, node.rpdo)
                       for pdo in pdos.map.values()}
        finally:
            network.disconnect()
    assert cob_ids == {layout.cob_id(twin.node_id) for layout in description.pdos}


def _mapped_bytes(description: DeviceDescription) -> list[tuple[str, int, int]]:
    """(PDO name, bytes its EDS mapping maps, shortest frame taken) for every PDO."""
    od: Any = object_dictionary(description)
    found = []
    for obj in description.table.objects:
        cob = description.table.get(obj.index, 1)
        if not (0x1400 <= obj.index <= 0x15FF or 0x1800 <= obj.index <= 0x19FF) \
                or cob is None or not isinstance(cob.default, NodeIdRelative):
            continue
        mapping = od[obj.index + 0x200]
        bits = sum(mapping[sub].default & 0xFF for sub in range(1, mapping[0].default + 1))
        for layout in description.pdos:
            if layout.cob_base == cob.default.offset:
                found.append((layout.name, (bits + 7) // 8, layout.min_length))
    return found


@pytest.mark.parametrize("device", DEVICES)
def test_a_pdo_of_the_length_the_eds_maps_is_taken(device: str) -> None:
    """What a CANopen stack configured from our EDS sends (its DLC = the mapped bytes) is not
    ignored as too short (the PKP-3500-MT encoder PDOs wanted 8 bytes, 1A01h maps 4)."""
    spec, _, quirks = device.partition(":")
    pdos = _mapped_bytes(describe_device(spec, quirks))
    assert pdos
    short = [(name, mapped, shortest) for name, mapped, shortest in pdos
             if mapped and shortest > mapped]  # a mapping of nothing carries no value
    assert short == []
