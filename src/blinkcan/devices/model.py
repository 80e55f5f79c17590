"""A device description: everything about one model, generation and quirk profile, as data."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal, get_args

from blinkcan.devices.common import ConsumerHeartbeat
from blinkcan.devices.objects import ObjectTable
from blinkcan.devices.pdo import Direction, PdoLayout
from blinkcan.protocol.nmt import NmtCommand

Quirks = Literal["firmware", "cia301"]
QUIRK_PROFILES: tuple[str, ...] = get_args(Quirks)


def check_quirks(quirks: str) -> Quirks:
    if quirks not in QUIRK_PROFILES:
        raise ValueError(f"quirks must be one of {', '.join(QUIRK_PROFILES)}, not {quirks!r}")
    return quirks  # type: ignore[return-value]


@dataclass(frozen=True)
class DeviceDescription:
    """One device model at one firmware generation, in one quirk profile (errata.md)."""

    model: str
    kind: str
    generation: str
    quirks: Quirks
    table: ObjectTable
    pdos: tuple[PdoLayout, ...]
    default_node_id: int
    #: baud-rate object code -> bit/s (errata B1: the two devices use different codes)
    bitrates: dict[int, int]
    #: extra NMT command bytes the device accepts (keypad: 00h = stop, errata P12)
    nmt_aliases: dict[int, NmtCommand] = field(default_factory=dict)
    #: what 1016h/01 accepts, where the device has a consumer heartbeat (None: it has none)
    consumer_heartbeat: ConsumerHeartbeat | None = None
    #: entry name -> the default the EDS states instead of the table's, where a master that
    #: configures itself from the EDS must see another value than an SDO read returns
    eds_defaults: dict[str, int] = field(default_factory=dict)

    def pdo(self, name: str) -> PdoLayout:
        for layout in self.pdos:
            if layout.name == name:
                return layout
        raise KeyError(f"{self.model} has no PDO named {name!r}")

    @property
    def rx_pdos(self) -> tuple[PdoLayout, ...]:
        return tuple(p for p in self.pdos if p.direction is Direction.RX)

    @property
    def tx_pdos(self) -> tuple[PdoLayout, ...]:
        return tuple(p for p in self.pdos if p.direction is Direction.TX)

    def bitrate_code(self, bitrate: int) -> int:
        """The baud-rate object code for a bit rate (the lowest code where several match)."""
        for code, rate in sorted(self.bitrates.items()):
            if rate == bitrate:
                return code
        valid = ", ".join(str(r) for r in sorted(set(self.bitrates.values())))
        raise ValueError(f"{self.model} does not run at {bitrate} bit/s; valid: {valid}")
