"""Our object table as a python-canopen ``ObjectDictionary``, built with its own classes.

The interop tests load it into a ``RemoteNode``; the EDS writer exports it with ``export_od``.
"""

from __future__ import annotations

from typing import Any

import canopen.objectdictionary as cod

from blinkcan.devices.model import DeviceDescription
from blinkcan.devices.objects import NodeIdRelative, ObjectEntry, ObjectKind


def _variable(entry: ObjectEntry, name: str, node_id: int) -> Any:
    variable: Any = cod.ODVariable(name, entry.index, entry.subindex)
    variable.data_type = int(entry.data_type)
    variable.access_type = entry.access.value
    variable.pdo_mappable = entry.pdo_mappable
    variable.unit = entry.unit
    variable.description = entry.doc
    if entry.valid is not None:
        variable.min, variable.max = entry.valid.low, entry.valid.high
    default = entry.default
    if isinstance(default, NodeIdRelative):
        # python-canopen keeps the value resolved and the $NODEID form for the EDS text
        variable.relative = True
        variable.default = default.resolve(node_id)
        variable.default_raw = f"$NODEID+0x{default.offset:X}"
    else:
        variable.default = default
    variable.storage_location = "PERSIST_COMM" if entry.stored else "RAM"
    return variable


def object_dictionary(description: DeviceDescription, node_id: int | None = None
                      ) -> Any:
    """A python-canopen object dictionary for ``description`` (node id for $NODEID values)."""
    od: Any = cod.ObjectDictionary()  # type: ignore[no-untyped-call]
    od.node_id = node_id if node_id is not None else description.default_node_id
    od.device_information.product_name = description.table["model_id"].default
    od.device_information.vendor_name = "Blink Marine"
    od.device_information.vendor_number = description.table["vendor_id"].default
    bitrates = sorted(set(description.bitrates.values()))
    od.device_information.allowed_baudrates = set(bitrates)
    for obj in description.table.objects:
        if obj.kind is ObjectKind.VAR:
            od.add_object(_variable(obj.entries[0], obj.label, od.node_id))
            continue
        kind = cod.ODArray if obj.kind is ObjectKind.ARRAY else cod.ODRecord
        container: Any = kind(obj.label, obj.index)
        for entry in obj.entries:
            container.add_member(_variable(entry, entry.label, od.node_id))
        od.add_object(container)
    return od
