"""The byte-padded Blink keypads (PKP-2200-SI .. PKP-3500-SI): one description builder.

They run the PKP-2600-SI's generation-2 firmware (pkp-rev1.1-vs-rev1.5.md: SYNC, 1016h, 1011h
acknowledged 43h, node id at once, 1800h/05 range), with three differences stated as data, so
twin, driver, decoder, EDS and DBC need no code of their own:

* the LED PDOs 215h/315h carry one mask per colour padded to whole bytes (``mask_bits``: 16,
  little-endian, on the 2300-SI..3500-SI; 8 on the 2200-SI), 2001h/2002h sub 01-03 being those
  words (pkp-2500-si-canopen.md p. 11/12/32);
* the key-state PDO carries ``key_bits`` key bits (1A00h/01, pkp-2400-si-canopen.md p. 32);
* 415h = indicator level, 515h = backlight level with no colour byte (pkp-2500-si p. 9).

A model is a :class:`BytePaddedKeypad`: its identity, face and evidence. ``evidence`` says
which facts come from the model's own pages and which are inferred (``I-n``): the one place an
inferred value lives, so a page that turns up corrects it here.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import partial

from blinkcan.devices.common import pdo_mapping
from blinkcan.devices.keypad import (
    GENERATION_2_FEATURES,
    KIND,
    describe_keypad,
    led_masks,
)
from blinkcan.devices.model import DeviceDescription, Face, LedField, Model, Quirks
from blinkcan.devices.objects import Access, mapping_value, record, u8, u16
from blinkcan.devices.pdo import Direction, PdoLayout, PdoSignal
from blinkcan.protocol.cob import RPDO1, RPDO2, RPDO4, TPDO1

#: the firmware generation of the family's public pages (SYNC-capable RPDOs, 1016h, 1011h)
GENERATION = "2"
COLOURS = ("red", "green", "blue")


@dataclass(frozen=True)
class BytePaddedKeypad:
    """One byte-padded keypad model: what differs from its siblings, and what rests on what.

    ``grid`` is the keys row by row from the front; ``evidence`` lines read "seen p. N: ..." or
    "I-n: ... (inferred from ...)", with no "=" (EDS [Comments] lines are key=value).
    """

    name: str
    title: str
    model_id: str
    grid: tuple[tuple[int, ...], ...]
    mask_bits: int
    key_bits: int
    evidence: tuple[str, ...]
    eds_date: str = "01-01-2024"

    def __post_init__(self) -> None:
        if any("=" in line for line in self.evidence):
            raise ValueError(f"{self.name}: evidence lines must hold no '=' (EDS [Comments])")

    @property
    def keys(self) -> int:
        return sum(1 for row in self.grid for key in row if key)

    @property
    def face(self) -> Face:
        return Face(keys=self.keys, grid=self.grid, led_colours=COLOURS,
                    led_keys=tuple(range(1, self.keys + 1)))

    @property
    def led_fields(self) -> tuple[LedField, ...]:
        """2001h/2002h sub 01-03 = red, green, blue words (pkp-2500-si p. 11/12)."""
        return tuple(LedField(n, colour, colour, (n - 1) * self.mask_bits, self.mask_bits)
                     for n, colour in enumerate(COLOURS, start=1))

    def led_pdo(self, name: str, label: str, cob_base: int) -> PdoLayout:
        """215h/315h: one ``mask_bits`` word per colour, red first, bit 0 = LED 1."""
        return PdoLayout(name, label, cob_base, Direction.RX, 8, tuple(
            PdoSignal(colour, f"{label} {colour}", shift * self.mask_bits, self.mask_bits,
                      None, item="LED", items=self.keys)
            for shift, colour in enumerate(COLOURS)
        ), min_length=3 * self.mask_bits // 8)

    def pdos(self, base: tuple[PdoLayout, ...]) -> tuple[PdoLayout, ...]:
        own = {
            "key_state": PdoLayout("key_state", "Keys state", TPDO1, Direction.TX, 5, (
                PdoSignal("keys", "Keys pressed", 0, self.key_bits, "keys_pressed", item="key",
                          items=self.keys),
                PdoSignal("tick", "Tick timer", 32, 8, None),  # errata P8, as the 2600
            ), min_length=1, period="tpdo1_event_timer"),  # 1800h/05 periodic transmission
            "led_on": self.led_pdo("led_on", "Set LED on", RPDO1),
            "led_blink": self.led_pdo("led_blink", "Set LED blink", RPDO2),
            # pkp-2500-si p. 9: byte 0 the level, no colour byte (unlike 2600 rev 1.5 §15)
            "backlight_brightness": PdoLayout(
                "backlight_brightness", "Backlight brightness", RPDO4, Direction.RX, 8,
                (PdoSignal("level", "Brightness level", 0, 8, "backlight_brightness"),),
                min_length=1),
        }
        return tuple(own.get(p.name, p) for p in base)

    def describe(self, generation: str, quirks: Quirks, factory_node_id: int
                 ) -> DeviceDescription:
        base = describe_keypad("1.5", quirks, factory_node_id)
        fields = self.led_fields
        width = self.mask_bits
        table = base.table.with_entries(
            model_id={"default": self.model_id},
            backlight_colour={"pdo_mappable": False},  # 515h has no colour byte
        ).with_objects(
            led_masks(0x2001, "led_on", "Digital output module, LED on", "LED on", fields),
            led_masks(0x2002, "led_blink", "Digital output module, LED blink", "LED blink",
                       fields),
            pdo_mapping(0x1600, "RPDO 1 mapping parameter", "rpdo1_mapping",
                     tuple(mapping_value(0x2001, f.subindex, width) for f in fields)),
            pdo_mapping(0x1601, "RPDO 2 mapping parameter", "rpdo2_mapping",  # 2500-SI p. 32
                     tuple(mapping_value(0x2002, f.subindex, width) for f in fields)),
            pdo_mapping(0x1603, "RPDO 4 mapping parameter", "rpdo4_mapping",
                     (mapping_value(0x2003, 2, 8),)),
            pdo_mapping(0x1A00, "TPDO 1 mapping parameter", "tpdo1_mapping",  # 2400-SI p. 32
                     (mapping_value(0x2000, 1, self.key_bits),)),
            # 2000h/01 as wide as 1A00h/01 maps it (2400-SI p. 32: 8 bits)
            record(0x2000, "digital_inputs", "Digital input module, keys states", (
                (u8 if self.key_bits <= 8 else u16)(1, "keys_pressed", "Keys pressed", Access.RO,
                                                    0, pdo_mappable=True),
            )),
        )
        return replace(
            base,
            model=self.name,
            generation=generation,
            table=table,
            pdos=self.pdos(base.pdos),
            face=self.face,
            led_fields=fields,
            features=GENERATION_2_FEATURES - {"backlight-colour-pdo"},
            title=self.title,
            edition="generation 2 (the public pages; revision unknown)",
            eds_file=f"{self.name}.eds",
            eds_date=self.eds_date,
            eds_defaults={},
            evidence=self.evidence,
        )

    @property
    def model(self) -> Model:
        """The registry entry: a keypad the PKP-2600-SI's twin and driver run."""
        return Model(
            name=self.name,
            kind=KIND,
            aliases=(),
            generations=(GENERATION,),
            default_node_id=0x15,  # every example of the pages uses 615h/595h
            describe=partial(BytePaddedKeypad.describe, self),
            twin="blinkcan.twin.keypad:KeypadTwin",
            driver="blinkcan.host.keypad:Keypad",
        )
