"""Communication-profile objects both devices implement the same way (CiA 301 area 1000h-1FFFh).

The values differ per device; the layout does not.
"""

from __future__ import annotations

from dataclasses import dataclass

from blinkcan.devices.objects import (
    Access,
    ObjectDef,
    Ranges,
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


@dataclass(frozen=True)
class ConsumerHeartbeat:
    """What 1016h/01 accepts (KBX §28, PKP rev 1.5 §26, errata K8/G4): bits 0-15 the time in
    ms, bits 16-23 the watched node 01h-7Fh, bits 24-31 zero. The twin and the drivers both
    read this, so they agree on the range."""

    times_ms: Ranges  # 0 (off) included
    may_watch_itself: bool = True

    @staticmethod
    def split(value: int) -> tuple[int, int, int]:
        """(time ms, node id, reserved byte) of a 1016h/01 value."""
        return value & 0xFFFF, (value >> 16) & 0xFF, value >> 24

    @staticmethod
    def compose(time_ms: int, node_id: int) -> int:
        return time_ms | node_id << 16

    def accepts(self, value: int, own_node_id: int) -> bool:
        time_ms, node, reserved = self.split(value)
        own = node == own_node_id and not self.may_watch_itself
        return not reserved and not own and 1 <= node <= 0x7F and time_ms in self.times_ms


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


def pdo_mapping(index: int, label: str, prefix: str, targets: tuple[int, ...]) -> ObjectDef:
    """1600h-1603h, 1A00h-1A03h: the mapping entries exactly as the manual prints them
    (errata P7, M42, M71), read-only; no targets is an empty mapping (sub 00h = 0, 1A03h of
    the PKP-3500-MT, spec M50)."""
    return record(index, prefix, label, tuple(
        u32(i, f"{prefix}_entry_{i}", f"PDO mapping entry {i}", Access.RO, target)
        for i, target in enumerate(targets, start=1)
    ), highest=len(targets))
