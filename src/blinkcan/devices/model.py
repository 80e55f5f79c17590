"""A device description: everything about one model, generation and quirk profile, as data."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, fields
from functools import cache
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
class LedField:
    """One sub-index of 2001h/2002h as a bit field of a keypad's LED word (PKP §11)."""

    subindex: int
    suffix: str
    label: str
    shift: int
    width: int


@dataclass(frozen=True)
class Encoder:
    """A rotary encoder: its number, the key its push is, its ring LEDs (clockwise from six
    o'clock) and the PDO that reports it."""

    number: int
    key: int
    ring_leds: tuple[int, ...]
    pdo: str


@dataclass(frozen=True)
class Face:
    """What a person presses, turns, sees and wires on the device. Drivers check arguments,
    the CLI and the panel draw it, from here alone.

    ``grid`` holds key numbers row by row as seen from the front (0: no key there).
    ``led_colours`` the LED channels under a key; ``led_keys`` the keys that have one (keys
    whose LED bit is a hole in the PDO, such as an encoder's, do not).
    """

    keys: int = 0
    grid: tuple[tuple[int, ...], ...] = ()
    led_colours: tuple[str, ...] = ()
    led_keys: tuple[int, ...] = ()
    encoders: tuple[Encoder, ...] = ()
    analog_inputs: int = 0
    analog_volts_max: float = 0.0
    digital_inputs: int = 0
    pins: int = 0
    pwm_pins: tuple[int, ...] = ()
    #: the highest PWM duty level, 100 %: duty goes 0..pwm_duty_max in equal steps
    pwm_duty_max: int = 0
    low_side_capable: tuple[int, ...] = ()

    @property
    def key_numbers(self) -> range:
        return range(1, self.keys + 1)

    @property
    def pin_numbers(self) -> range:
        return range(1, self.pins + 1)


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
    face: Face = Face()
    #: 2001h/2002h sub-indices as fields of the LED word (keypads)
    led_fields: tuple[LedField, ...] = ()
    #: behaviours a twin or driver switches on: "sync" (SYNC-driven PDOs, errata G3),
    #: "node-id-at-once" (G1), "backlight-colour-pdo" (G2)
    features: frozenset[str] = frozenset()
    #: "PKP-2600-SI keypad": how people call it; "generation 2 (manual rev 1.5)": which one
    title: str = ""
    edition: str = ""
    #: the shipped EDS file's name and date (the manual revision's date, MM-DD-YYYY)
    eds_file: str = ""
    eds_date: str = "01-01-2024"
    #: entry name -> the default the EDS states instead of the table's, where a master that
    #: configures itself from the EDS must see another value than an SDO read returns
    eds_defaults: dict[str, int] = field(default_factory=dict)
    #: what rests on what: "seen p. N: ..." (the model's own pages) or "I-n: ..." (inferred
    #: from siblings); the EDS [Comments] and ``blinkcan info`` state it
    evidence: tuple[str, ...] = ()

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

    def sharing(self, other: DeviceDescription) -> DeviceDescription:
        """``other`` holding this description's parts wherever they are equal: the same model
        described at another factory node id (which is one entry's default) is then a few
        objects, not a second copy of the table, layouts and face."""
        parts: dict[str, object] = {}
        for part in fields(self):
            ours, theirs = getattr(self, part.name), getattr(other, part.name)
            if part.name == "table":
                parts[part.name] = self.table.sharing(theirs)
            else:
                parts[part.name] = ours if ours == theirs else theirs
        return DeviceDescription(**parts)  # type: ignore[arg-type]

    def bitrate_code(self, bitrate: int) -> int:
        """The baud-rate object code for a bit rate (the lowest code where several match)."""
        for code, rate in sorted(self.bitrates.items()):
            if rate == bitrate:
                return code
        valid = ", ".join(str(r) for r in sorted(set(self.bitrates.values())))
        raise ValueError(f"{self.model} does not run at {bitrate} bit/s; valid: {valid}")


Describe = Callable[[str, Quirks, int], DeviceDescription]


@dataclass(frozen=True)
class Model:
    """One entry of the model registry: names, generations, and which behaviour runs it.

    ``describe(generation, quirks, factory_node_id)`` builds a description. ``twin`` and
    ``driver`` name classes as ``"module:Class"``, imported only when used (the pure
    ``devices/`` layer imports neither).
    """

    name: str
    kind: str
    aliases: tuple[str, ...]
    generations: tuple[str, ...]
    default_node_id: int
    describe: Describe
    twin: str
    driver: str

    @property
    def names(self) -> tuple[str, ...]:
        return (self.name, *self.aliases)

    def description(self, generation: str | None = None, quirks: str = "firmware",
                    factory_node_id: int | None = None) -> DeviceDescription:
        generation = generation or self.generations[0]
        if generation not in self.generations:
            raise ValueError(f"{self.name} generations are {', '.join(self.generations)}, "
                             f"not {generation!r}")
        profile = check_quirks(quirks)
        described = _described(self, generation, profile)
        if factory_node_id is None or factory_node_id == self.default_node_id:
            return described
        # another factory node id: its own description, sharing every equal part
        return described.sharing(self.describe(generation, profile, factory_node_id))


@cache
def _described(model: Model, generation: str, quirks: Quirks) -> DeviceDescription:
    """A model's description at its default node id, built once (descriptions are immutable:
    every twin, driver and decoder of the model holds this one)."""
    return model.describe(generation, quirks, model.default_node_id)
