"""PDO layouts as data: which bits of which COB-ID carry which object entry.

The keypad's mapping objects do not describe its real PDOs (errata P7, P8), so layouts are their
own data, taken from the manuals' bit tables. Twins apply RPDOs and build TPDOs from them; the
decoder and the DBC writer read the same layouts.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from enum import Enum


class Direction(str, Enum):
    RX = "rx"  # to the device
    TX = "tx"  # from the device


@dataclass(frozen=True)
class PdoSignal:
    """``length`` bits at bit ``start`` (bit 0 = byte 0 bit 0, little-endian across the frame).

    ``entry`` names the object entry the bits carry, or None for bits that are not an object
    (the keypad's tick timer, PKP §10). ``item`` says the bits are a mask of numbered things
    (bit 0 = "key" 1, "LED" 1, "pin" 1), so the decoder and the DBC can name each one;
    ``items`` counts them where the mask is padded to whole bytes (the byte-padded keypads'
    LED words, pkp-2500-si-canopen.md p. 9).
    ``scale`` and ``unit`` give the physical value (10 mV per count: 0.01, "V");
    ``sign_magnitude``: the top bit is the sign, the others the magnitude (an encoder's
    direction counter, MT §12).
    """

    name: str
    label: str
    start: int
    length: int
    entry: str | None
    item: str | None = None
    scale: float = 1.0
    unit: str = ""
    sign_magnitude: bool = False
    #: how many of a mask's bits are items, the rest padding it to whole bytes (0: all)
    items: int = 0

    def physical(self, raw: int) -> int | float:
        """The value the bits mean: signed for sign-magnitude, scaled where a unit says so."""
        if self.sign_magnitude:
            top = 1 << (self.length - 1)
            raw = -(raw & (top - 1)) if raw & top else raw
        return raw * self.scale if self.scale != 1.0 else raw

    @property
    def mask(self) -> int:
        return (1 << self.length) - 1


@dataclass(frozen=True)
class PdoLayout:
    """One PDO: its COB-ID base (node id added), length and signals.

    ``min_length`` is the shortest frame the device acts on (errata P14: the brightness PDOs
    accept DLC 1..8); a shorter frame is ignored. ``period`` names the object entry that sets
    how often the device repeats this TPDO by itself (PKP §41b's event timer, KBX §25, MT §14);
    empty: the device sends it on a change only.
    """

    name: str
    label: str
    cob_base: int
    direction: Direction
    length: int
    signals: tuple[PdoSignal, ...]
    min_length: int = 0
    doc: str = ""
    period: str = ""

    def __post_init__(self) -> None:
        if not self.min_length:
            object.__setattr__(self, "min_length", self.length)

    def cob_id(self, node_id: int) -> int:
        return self.cob_base + node_id

    def decode(self, data: bytes) -> dict[str, int]:
        """Signal values of a frame (missing bytes read as zero)."""
        word = int.from_bytes(data, "little")
        return {s.name: (word >> s.start) & s.mask for s in self.signals}

    def encode(self, signal_values: Mapping[str, int]) -> bytes:
        """Frame bytes from signal values; unnamed signals are zero."""
        word = 0
        for s in self.signals:
            value = signal_values.get(s.name, 0)
            if not 0 <= value <= s.mask:
                raise ValueError(f"{self.name}.{s.name}: {value} outside 0..{s.mask}")
            word |= value << s.start
        return word.to_bytes(self.length, "little")

    def signal(self, name: str) -> PdoSignal:
        for s in self.signals:
            if s.name == name:
                return s
        raise KeyError(f"{self.name} has no signal {name!r}")
