"""Communication-profile objects both devices implement the same way (CiA 301 area 1000h-1FFFh).

The values differ per device; the layout does not.
"""

from __future__ import annotations

from blinkcan.devices.objects import (
    Access,
    ObjectDef,
    Sub,
    record,
    text,
    u16,
    u32,
    values,
    var,
)

#: 1017h and periodic timers (errata P1, P2, K17): 0 = off; upper bound FEFFh = 65279 ms.
TIMER_MS_MAX = 0xFEFF
#: 1011h sub 01h signature "load" (KBX §36, PKP rev 1.5 §34): UNSIGNED32 of 6C 6F 61 64
RESTORE_SIGNATURE = int.from_bytes(b"load", "little")


def device_type(value: int) -> ObjectDef:
    """1000h (PKP §26, KBX §30)."""
    return var(0x1000, "Device type", u32(0, "device_type", "Device type", Access.RO, value))


def identity_strings(
    device_name: str, hardware_version: str, software_version: str
) -> tuple[ObjectDef, ...]:
    """1008h, 1009h, 100Ah (PKP §28-§30, KBX §32-§34)."""
    return (
        var(0x1008, "Manufacturer device name",
            text(0, "manufacturer_device_name", "Manufacturer device name", device_name)),
        var(0x1009, "Manufacturer hardware version",
            text(0, "manufacturer_hardware_version", "Manufacturer hardware version",
                 hardware_version)),
        var(0x100A, "Manufacturer software version",
            text(0, "manufacturer_software_version", "Manufacturer software version",
                 software_version)),
    )


def model_id(value: str) -> ObjectDef:
    """100Bh, a manufacturer object both devices use for the model name (PKP §31, KBX §35)."""
    return var(0x100B, "Model ID", text(0, "model_id", "Model ID", value))


def producer_heartbeat_time(low: int) -> ObjectDef:
    """1017h in ms: 0 = off, else ``low``..65279 (errata P1, K17). Stored (errata, settings)."""
    return var(
        0x1017,
        "Producer heartbeat time",
        u16(0, "producer_heartbeat_time", "Producer heartbeat time", Access.RW, 0,
            valid=values(0, (low, TIMER_MS_MAX)), stored=True, unit="ms"),
    )


def identity(vendor_id: int, extra: tuple[Sub, ...] = ()) -> ObjectDef:
    """1018h: vendor id 000003E2h (PKP §32, KBX §37) and what else the device lists."""
    return record(0x1018, "identity", "Identity object",
                  (u32(1, "vendor_id", "Vendor-ID", Access.RO, vendor_id), *extra))

