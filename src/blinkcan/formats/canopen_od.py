"""Our object table as a python-canopen ``ObjectDictionary``, built with its own classes.

The interop tests load it into a ``RemoteNode``; the EDS writer exports it with ``export_od``.
Only CiA 306 keys go in: no StorageLocation and no Unit (python-canopen's own keys, which
CanFestival's objdictgen refuses), and every [DeviceInfo] key CiA 306 lists.

EDS readers, python-canopen's ``RemoteNode`` among them, pair every 14xxh/18xxh with its
16xxh/1Axxh, refuse a file without it, and read both from the device (``tpdo.read()``). So a
model's table has the pair, empty where the PDO's values are in no object (the PKP-3500-MT's
1A03h reads 0, MT M50 as revised); [Comments] says why. A communication record whose table
lacks its mapping record still gets one stated empty here (a device that aborts a read of it
breaks ``tpdo.read()``; [Comments] says so).
"""

from __future__ import annotations

from typing import Any

import canopen.objectdictionary as cod

from blinkcan.devices.model import DeviceDescription
from blinkcan.devices.objects import DataType, NodeIdRelative, ObjectEntry, ObjectKind
from blinkcan.devices.pdo import PdoLayout


def _variable(entry: ObjectEntry, name: str, node_id: int, stated: int | None = None) -> Any:
    """One entry; ``stated`` replaces its default (DeviceDescription.eds_defaults)."""
    variable: Any = cod.ODVariable(name, entry.index, entry.subindex)
    variable.data_type = int(entry.data_type)
    variable.access_type = entry.access.value
    variable.pdo_mappable = entry.pdo_mappable
    variable.description = entry.doc
    if entry.valid is not None:
        variable.min, variable.max = entry.valid.low, entry.valid.high
    default = entry.default if stated is None else stated
    if isinstance(default, NodeIdRelative):
        # python-canopen keeps the value resolved and the $NODEID form for the EDS text
        variable.relative = True
        variable.default = default.resolve(node_id)
        variable.default_raw = f"$NODEID+0x{default.offset:X}"
    else:
        variable.default = default
    return variable


def _mapping_counts(description: DeviceDescription) -> tuple[int, int]:
    """How many RPDOs and TPDOs the table has (1400h-15FFh, 1800h-19FFh: CiA 301 7.5)."""
    indexes = {obj.index for obj in description.table.objects}
    return (sum(0x1400 <= i <= 0x15FF for i in indexes),
            sum(0x1800 <= i <= 0x19FF for i in indexes))


def missing_mappings(description: DeviceDescription) -> list[int]:
    """Mapping records (16xxh, 1Axxh) of communication records the table has without them."""
    table = description.table
    return [obj.index + 0x200 for obj in table.objects
            if (0x1400 <= obj.index <= 0x15FF or 0x1800 <= obj.index <= 0x19FF)
            and not table.has_index(obj.index + 0x200)]


def empty_mappings(description: DeviceDescription) -> list[tuple[int, PdoLayout]]:
    """Mapping records that map nothing (sub 00h = 0) although the device sends or takes their
    PDO (the PKP-3500-MT's 1A03h: its analog values are in no object, MT M50), with the PDO."""
    table = description.table
    found = []
    for layout in description.pdos:
        for obj in table.objects:
            cob = table.get(obj.index, 1)
            if not (0x1400 <= obj.index <= 0x15FF or 0x1800 <= obj.index <= 0x19FF) \
                    or cob is None or not isinstance(cob.default, NodeIdRelative) \
                    or cob.default.offset != layout.cob_base:
                continue
            count = table.get(obj.index + 0x200, 0)
            if count is not None and count.default == 0:
                found.append((obj.index + 0x200, layout))
    return found


def _device_information(od: Any, description: DeviceDescription) -> None:
    table = description.table
    info = od.device_information
    info.product_name = table["model_id"].default
    info.order_code = table["model_id"].default
    info.vendor_name = "Blink Marine"
    info.vendor_number = table["vendor_id"].default
    for attribute, sub in (("product_number", 2), ("revision_number", 3)):  # 1018h/02, /03
        entry = table.get(0x1018, sub)
        setattr(info, attribute, entry.default if entry is not None else 0)
    info.allowed_baudrates = set(description.bitrates.values())
    info.simple_boot_up_master = False
    info.simple_boot_up_slave = True  # boot-up message and NMT slave (CiA 301)
    # the mapping objects are read-only: PDO mapping cannot be changed (granularity 0)
    info.granularity = 0
    info.dynamic_channels_supported = False
    info.group_messaging = False
    info.nr_of_RXPDO, info.nr_of_TXPDO = _mapping_counts(description)
    info.LSS_supported = False


def object_dictionary(description: DeviceDescription, node_id: int | None = None
                      ) -> Any:
    """A python-canopen object dictionary for ``description`` (node id for $NODEID values)."""
    od: Any = cod.ObjectDictionary()  # type: ignore[no-untyped-call]
    od.node_id = node_id if node_id is not None else description.default_node_id
    _device_information(od, description)
    stated = description.eds_defaults
    for obj in description.table.objects:
        if obj.kind is ObjectKind.VAR:
            entry = obj.entries[0]
            od.add_object(_variable(entry, obj.label, od.node_id, stated.get(entry.name)))
            continue
        kind = cod.ODArray if obj.kind is ObjectKind.ARRAY else cod.ODRecord
        container: Any = kind(obj.label, obj.index)
        for entry in obj.entries:
            container.add_member(_variable(entry, entry.label, od.node_id,
                                           stated.get(entry.name)))
        od.add_object(container)
    for index in missing_mappings(description):
        record: Any = cod.ODRecord("PDO mapping parameter (not in the device)", index)
        count: Any = cod.ODVariable("Number of mapped objects", index, 0)
        count.data_type, count.access_type, count.default = int(DataType.UNSIGNED8), "ro", 0
        record.add_member(count)
        od.add_object(record)
    return od
