"""Twins of one model share what the description says and keep only their own values (issue 22
target 7: 127 twins under 10 MB).

Sharing: two twins of a model hold the one description (the same objects, not equal copies),
at another factory node id everything but the entries that differ (2013h/2011h's default).
Isolation: whatever one twin accepts through SDO, another twin of the model reads and uploads
what it did before, value and wire bytes alike.
"""

from __future__ import annotations

import pytest

from blinkcan.devices.objects import DataType
from blinkcan.devices.registry import models
from blinkcan.twin.base import CanopenTwin
from blinkcan.twin.registry import build_twin

SPECS = [f"{found.name}@{generation}" for found in models() if found.default_node_id
         for generation in found.generations]


def _state(twin: CanopenTwin) -> dict[str, object]:
    """Every entry's value and SDO upload answer."""
    store = twin.objects
    return {entry.name: (store[entry.name], store.sdo_upload(entry.mux))
            for entry in store.entries()}


@pytest.mark.parametrize("spec", SPECS)
def test_twins_of_a_model_hold_one_description(spec: str) -> None:
    first, second = build_twin(spec), build_twin(spec)  # at the model's default node id
    assert first.description is second.description


@pytest.mark.parametrize("spec", SPECS)
@pytest.mark.parametrize("nodes", [(0x21, 0x22), (None, 0x22)])
def test_at_another_factory_node_id_only_what_differs_is_its_own(
        spec: str, nodes: tuple[int | None, int]) -> None:
    first, second = build_twin(spec, node_id=nodes[0]), build_twin(spec, node_id=nodes[1])
    ours, theirs = first.description, second.description
    assert ours.table.layout is theirs.table.layout
    assert (ours.pdos, ours.face, ours.led_fields) == (theirs.pdos, theirs.face,
                                                        theirs.led_fields)
    assert ours.pdos is theirs.pdos
    assert ours.face is theirs.face
    own = [(a, b) for a, b in zip(ours.table, theirs.table, strict=True) if a is not b]
    assert own  # the node id's default differs
    assert all(a != b for a, b in own)  # nothing equal is held twice
    assert first.objects["node_id"] == (nodes[0] or ours.default_node_id)
    assert second.objects["node_id"] == 0x22


@pytest.mark.parametrize("spec", SPECS)
def test_one_twins_writes_leave_another_twin_as_it_was(spec: str) -> None:
    writer, other = build_twin(spec, node_id=0x21), build_twin(spec, node_id=0x21)
    writer.power_on(0.0)
    other.power_on(0.0)
    before = _state(other)
    written = 0
    for entry in writer.description.table:
        if not entry.access.writable or entry.data_type is DataType.VISIBLE_STRING:
            continue
        current = writer.objects[entry.name]
        low, high = (entry.valid.low, entry.valid.high) if entry.valid else (0, 1)
        value = high if current != high else low
        size = entry.data_type.size or 4
        data = value.to_bytes(size, "little", signed=entry.data_type.is_signed)
        if writer.objects.sdo_download(entry.mux, data, True) == entry.acknowledge:
            written += 1
    assert written >= 5  # the test wrote something
    assert _state(other) == before
