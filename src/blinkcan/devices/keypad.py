"""PKP-2600-SI keypad: object table and PDO layouts, manual rev 1.1 (the seed manual).

Every object the manual documents is here once; § numbers are the manual's. Where the manual
contradicts itself the errata.md decision is applied and cited.
"""

from __future__ import annotations

from blinkcan.devices.common import (
    TIMER_MS_MAX,
    ConsumerHeartbeat,
    device_type,
    identity,
    identity_strings,
    model_id,
    pdo_mapping,
    producer_heartbeat_time,
)
from blinkcan.devices.model import (
    DeviceDescription,
    Face,
    LedField,
    Model,
    Quirks,
    check_quirks,
)
from blinkcan.devices.objects import (
    Access,
    NodeIdRelative,
    ObjectDef,
    ObjectKind,
    ObjectTable,
    mapping_value,
    record,
    text,
    u8,
    u16,
    u32,
    values,
    var,
)
from blinkcan.devices.pdo import Direction, PdoLayout, PdoSignal
from blinkcan.protocol.cob import RPDO1, RPDO2, RPDO3, RPDO4, TPDO1
from blinkcan.protocol.nmt import NmtCommand

MODEL = "pkp-2600-si"
KIND = "keypad"
GENERATIONS = ("1.1", "1.5")
KEY_COUNT = 12
DEFAULT_NODE_ID = 0x15  # PKP §3
VENDOR_ID = 0x000003E2  # PKP §32
#: generation 2 (rev 1.5 §26, errata G4): 0 = off, 10..65535 ms; not the keypad's own id
CONSUMER_HEARTBEAT = ConsumerHeartbeat(values(0, (10, 0xFFFF)), may_watch_itself=False)
SERIAL_NUMBER = "FFFFFFFF"  # PKP §43, an unprogrammed unit
#: Key LED bit table (PKP §11, §12; errata P7, P13): red bits 0-11, green 12-23, blue 24-35.
LED_BITS_PER_COLOUR = KEY_COUNT
LEVEL_MAX = 0x3F  # PKP §13/§14/§18: 00h-3Fh, 3Fh = 100 % (errata P15)
TICK_PERIOD_S = 0.1  # errata P8: the key PDO's byte 4 advances every 100 ms

#: 2010h codes (PKP §19, errata B1): reserved codes run at 125k.
BITRATES = {
    0x00: 1_000_000,
    0x01: 125_000,
    0x02: 500_000,
    0x03: 250_000,
    0x04: 125_000,
    0x05: 125_000,
    0x06: 50_000,
    0x07: 20_000,
}

#: 2014h startup LED show (PKP §23)
SHOW_OFF, SHOW_COMPLETE, SHOW_FAST_FLASH = 0, 1, 2
#: 20FFh/01h (PKP §44)
PROTOCOL_CANOPEN, PROTOCOL_J1939 = 0, 1

_LEVEL = values((0, LEVEL_MAX))
_COLOUR = values((0x01, 0x09))  # PKP §18c/d: 01h red .. 09h yellow/green
_FLAG = values(0, 1)
_TIMER = values(0, (10, TIMER_MS_MAX))  # errata P1/P2: 0 = off, 10..65279 ms


def _rpdo_parameter(index: int, cob_base: int, label: str) -> ObjectDef:
    """1400h-1403h (PKP §33-§36): COB-ID and transmission type FEh, read-only in rev 1.1."""
    n = index - 0x1400 + 1
    return record(index, f"rpdo{n}_parameter", label, (
        u32(1, f"rpdo{n}_cob_id", "COB-ID used by RPDO", Access.RO, NodeIdRelative(cob_base)),
        u8(2, f"rpdo{n}_transmission_type", "Transmission type", Access.RO, 0xFE),
    ))


#: rev 1.1 §16/§17: one 12-bit mask per colour. rev 1.5 §17/§18 (rev 1.3 history): the
#: sub-indices follow the PDO bytes: red 1-12 + green 1-4, green 5-12, blue 1-12.
LED_FIELDS: dict[str, tuple[LedField, ...]] = {
    "1.1": (LedField(1, "red", "red", 0, 12), LedField(2, "green", "green", 12, 12),
            LedField(3, "blue", "blue", 24, 12)),
    "1.5": (LedField(1, "red_green", "red 1-12, green 1-4", 0, 16),
            LedField(2, "green", "green 5-12", 16, 8),
            LedField(3, "blue", "blue 1-12", 24, 12)),
}


def led_masks(index: int, prefix: str, label: str, what: str,
               fields: tuple[LedField, ...]) -> ObjectDef:
    """2001h LED on / 2002h LED blink: each sub-index a field of the LED word."""
    return record(index, prefix, label, tuple(
        (u16 if f.width > 8 else u8)(f.subindex, f"{prefix}_{f.suffix}", f"{what} {f.label}",
                                     Access.RW, 0, valid=values((0, (1 << f.width) - 1)),
                                     pdo_mappable=True)
        for f in fields
    ))


def _table(factory_node_id: int, quirks: Quirks) -> ObjectTable:
    # errata P5/P6 (Q): the firmware sends 1009h and 100Ah reversed, as the manual prints them.
    hardware, software = "V_01", "V2.2"
    if quirks == "firmware":
        hardware, software = hardware[::-1], software[::-1]
    return ObjectTable((
        device_type(0x000B0191),  # PKP §26, errata B5
        # 1001h: "not yet implemented in the device" (PKP §27): absent, so 0602 0000h.
        *identity_strings("BlinkMarine", hardware, software),  # PKP §28-§30
        model_id("PKP2600SI"),  # PKP §31
        producer_heartbeat_time(10),  # PKP §25, errata P1
        identity(VENDOR_ID, (  # PKP §32, errata P18: 02h/03h undocumented, read 0
            u32(2, "product_code", "Product code", Access.RO, 0),
            u32(3, "revision_number", "Revision number", Access.RO, 0),
            u32(4, "serial_number", "Serial number", Access.RO, int(SERIAL_NUMBER, 16)),
        )),
        _rpdo_parameter(0x1400, RPDO1, "RPDO 1 communication parameter (LED on)"),
        _rpdo_parameter(0x1401, RPDO2, "RPDO 2 communication parameter (LED blink)"),
        _rpdo_parameter(0x1402, RPDO3, "RPDO 3 communication parameter (indicator brightness)"),
        _rpdo_parameter(0x1403, RPDO4, "RPDO 4 communication parameter (backlight brightness)"),
        pdo_mapping(0x1600, "RPDO 1 mapping parameter", "rpdo1_mapping", (
            mapping_value(0x2001, 1, 8), mapping_value(0x2001, 2, 8), mapping_value(0x2001, 3, 8),
        )),
        pdo_mapping(0x1601, "RPDO 2 mapping parameter", "rpdo2_mapping", (
            mapping_value(0x2002, 1, 8), mapping_value(0x2002, 2, 8), mapping_value(0x2002, 3, 8),
        )),
        pdo_mapping(0x1602, "RPDO 3 mapping parameter", "rpdo3_mapping",  # errata P16
                 (mapping_value(0x2003, 1, 8),)),
        pdo_mapping(0x1603, "RPDO 4 mapping parameter", "rpdo4_mapping",  # errata P17
                 (mapping_value(0x2003, 2, 8),)),
        record(0x1800, "tpdo1_parameter", "TPDO 1 communication parameter (key state)", (
            u32(1, "tpdo1_cob_id", "COB-ID used by TPDO", Access.RO, NodeIdRelative(TPDO1)),
            u8(2, "tpdo1_transmission_type", "Transmission type", Access.RO, 0xFE),
            # PKP §41b, errata P2/P3: ms, 0 = off, read back with 4Bh
            u16(5, "tpdo1_event_timer", "Event timer", Access.RW, 0, valid=_TIMER, stored=True,
                unit="ms"),
        )),
        pdo_mapping(0x1A00, "TPDO 1 mapping parameter", "tpdo1_mapping",  # PKP §42, errata P8
                 (mapping_value(0x2000, 1, 16),)),
        record(0x2000, "digital_inputs", "Digital input module, keys states", (  # PKP §15
            u16(1, "keys_pressed", "Keys pressed", Access.RO, 0, pdo_mappable=True),
        )),
        led_masks(0x2001, "led_on", "Digital output module, LED on", "LED on",
                   LED_FIELDS["1.1"]),
        led_masks(0x2002, "led_blink", "Digital output module, LED blink", "LED blink",
                   LED_FIELDS["1.1"]),
        record(0x2003, "brightness", "Brightness level", (  # PKP §18
            u8(1, "indicator_brightness", "Indicator LED brightness", Access.RW, LEVEL_MAX,
               valid=_LEVEL, power_on_from="startup_indicator_brightness", pdo_mappable=True),
            u8(2, "backlight_brightness", "Backlight brightness", Access.RW, 0, valid=_LEVEL,
               power_on_from="startup_backlight_brightness", pdo_mappable=True),
            u8(3, "backlight_colour", "Backlight colour", Access.RW, 0x08, valid=_COLOUR,
               power_on_from="default_backlight_colour"),
            u8(4, "default_backlight_colour", "Default backlight colour", Access.RW, 0x08,
               valid=_COLOUR, stored=True),
            u8(5, "startup_indicator_brightness", "Startup indicator LED brightness", Access.RW,
               LEVEL_MAX, valid=_LEVEL, stored=True),
            u8(6, "startup_backlight_brightness", "Startup backlight brightness", Access.RW, 0,
               valid=_LEVEL, stored=True),
        )),
        var(0x2010, "Baud rate setting", u8(0, "baud_rate", "Baud rate", Access.RW, 0x04,
            valid=values((0, 7)), stored=True)),  # PKP §19, errata B1
        var(0x2011, "Boot-up service", u8(0, "boot_up_service", "Boot-up service", Access.RW, 1,
            valid=_FLAG, stored=True)),  # PKP §20
        var(0x2012, "Device active on startup", u8(0, "active_on_startup",
            "Device active on startup", Access.RW, 0, valid=_FLAG, stored=True)),  # PKP §21
        var(0x2013, "CANopen node ID", u8(0, "node_id", "CANopen node ID", Access.RW,
            factory_node_id, valid=values((1, 0x7F)), stored=True)),  # PKP §22, errata P11
        var(0x2014, "Startup LED show", u8(0, "startup_led_show", "Startup LED show", Access.RW,
            SHOW_COMPLETE, valid=values((0, 2)), stored=True)),  # PKP §23
        record(0x20FF, "can_protocol_switch", "Set CAN protocol", (  # PKP §44, errata P10
            u16(1, "can_protocol", "CAN protocol", Access.RW, PROTOCOL_CANOPEN,
                valid=values(PROTOCOL_CANOPEN, PROTOCOL_J1939), stored=True),
        )),
        var(0x2100, "DEMO mode", u8(0, "demo_mode", "DEMO mode", Access.RW, 0, valid=_FLAG,
            stored=True)),  # PKP §24
        var(0x2200, "Serial number string", text(0, "serial_number_string",
            "Serial number string", SERIAL_NUMBER)),  # PKP §43
    ))


def _led_pdo(name: str, label: str, cob_base: int, prefix: str) -> PdoLayout:
    """200h/300h + id (PKP §11/§12, errata P7/P13): red 0-11, green 12-23, blue 24-35, the
    same in both generations. The twin keeps this 36-bit word; 2001h/2002h are its views."""
    return PdoLayout(name, label, cob_base, Direction.RX, 8, tuple(
        PdoSignal(colour, f"{label} {colour}", shift * LED_BITS_PER_COLOUR, LED_BITS_PER_COLOUR,
                  None, item="LED")
        for shift, colour in enumerate(("red", "green", "blue"))
    ), min_length=5)


def _pdos() -> tuple[PdoLayout, ...]:
    return (
        PdoLayout("key_state", "Keys state", TPDO1, Direction.TX, 5, (  # PKP §10, errata P8
            PdoSignal("keys", "Keys pressed", 0, KEY_COUNT, "keys_pressed", item="key"),
            PdoSignal("tick", "Tick timer", 32, 8, None),
        ), min_length=2, period="tpdo1_event_timer"),  # PKP §41b: periodic state transmission
        _led_pdo("led_on", "Set LED on", RPDO1, "led_on"),
        _led_pdo("led_blink", "Set LED blink", RPDO2, "led_blink"),
        PdoLayout("indicator_brightness", "Indicator LEDs brightness", RPDO3, Direction.RX, 8, (
            PdoSignal("level", "Brightness level", 0, 8, "indicator_brightness"),
        ), min_length=1),  # PKP §13, errata P14/P15
        PdoLayout("backlight_brightness", "Backlight brightness", RPDO4, Direction.RX, 8, (
            PdoSignal("level", "Brightness level", 0, 8, "backlight_brightness"),
        ), min_length=1),  # PKP §14, errata P14/P15
    )


def _rev15_table(base: ObjectTable, factory_node_id: int, quirks: Quirks) -> ObjectTable:
    """Manual rev 1.5 (firmware V2.8) as a delta over rev 1.1 (pkp-rev1.1-vs-rev1.5.md §1)."""
    sync_rpdo = values((0x00, 0xF0), 0xFE)  # rev 1.5 §36/§37, errata G3
    sync_tpdo = values((0x01, 0xF0), 0xFE)  # rev 1.5 §44a: 00h not listed
    restore_ack = 0x43 if quirks == "firmware" else 0x60  # errata G5
    table = base.with_entries(
        # rev 1.5 §31/§32: sent in order in both profiles (diff item 19)
        manufacturer_hardware_version={"default": "V_01"},
        manufacturer_software_version={"default": "V2.8"},
        # writable, live (not stored: rev 1.5 is silent, errata lists no PDO types as stored)
        rpdo1_transmission_type={"access": Access.RW, "valid": sync_rpdo},
        rpdo2_transmission_type={"access": Access.RW, "valid": sync_rpdo},
        tpdo1_transmission_type={"access": Access.RW, "valid": sync_tpdo},
        backlight_colour={"pdo_mappable": True},  # rev 1.5 §43: 1603h/02 maps 2003h/03
    )
    fields = LED_FIELDS["1.5"]
    return table.with_objects(
        led_masks(0x2001, "led_on", "Digital output module, LED on", "LED on", fields),
        led_masks(0x2002, "led_blink", "Digital output module, LED blink", "LED blink",
                   fields),
        pdo_mapping(0x1600, "RPDO 1 mapping parameter", "rpdo1_mapping", (  # rev 1.5 §40
            mapping_value(0x2001, 1, 16), mapping_value(0x2001, 2, 8),
            mapping_value(0x2001, 3, 16))),
        pdo_mapping(0x1601, "RPDO 2 mapping parameter", "rpdo2_mapping", (  # rev 1.5 §41
            mapping_value(0x2002, 1, 16), mapping_value(0x2002, 2, 8),
            mapping_value(0x2002, 3, 16))),
        pdo_mapping(0x1603, "RPDO 4 mapping parameter", "rpdo4_mapping", (  # rev 1.5 §43
            mapping_value(0x2003, 2, 8), mapping_value(0x2003, 3, 8))),
        record(0x1016, "consumer_heartbeat", "Consumer heartbeat time", (  # rev 1.5 §26, G4
            # bits 0-15 time in ms (0 = off, 10..65535), bits 16-23 node 01h-7Fh, 24-31 zero
            u32(1, "consumer_heartbeat_time", "Consumer heartbeat time", Access.RW,
                0x0001_0000, stored=True),
        )),
        record(0x1011, "restore_default_parameters", "Restore default parameters", (  # §34
            u32(1, "restore_all_parameters", "Restore all default parameters", Access.RW, 1,
                acknowledge=restore_ack),
        )),
    )


def _rev15_pdos(pdos: tuple[PdoLayout, ...]) -> tuple[PdoLayout, ...]:
    """rev 1.5 §15: the backlight PDO carries the colour in byte 1 (errata G2)."""
    backlight = PdoLayout("backlight_brightness", "Backlight setting", RPDO4, Direction.RX, 8, (
        PdoSignal("level", "Brightness level", 0, 8, "backlight_brightness"),
        PdoSignal("colour", "Colour (00h: the default colour)", 8, 8, None),
    ), min_length=1)
    return tuple(backlight if p.name == "backlight_brightness" else p for p in pdos)


def _eds_led_mappings(generation: str) -> dict[str, int]:
    """What the EDS states for 1600h/1601h in rev 1.1 (errata P7).

    The device answers SDO reads with the 8-bit entries the manual prints, but the frame it acts
    on packs three 12-bit masks into bytes 0-4 (PKP §11/§12). A master that configures its RPDOs
    from the EDS must build that frame, so the EDS maps each 16-bit mask object with 12 bits,
    which is exactly the packed layout. Rev 1.5's printed entries (16 + 8 + 16 bits) already
    cover bytes 0-4 and are stated as printed.
    """
    if generation != "1.1":
        return {}
    return {f"rpdo{n}_mapping_entry_{f.subindex}": mapping_value(index, f.subindex, f.width)
            for n, index in ((1, 0x2001), (2, 0x2002)) for f in LED_FIELDS["1.1"]}


def describe_keypad(
    generation: str = "1.1",
    quirks: Quirks = "firmware",
    factory_node_id: int = DEFAULT_NODE_ID,
) -> DeviceDescription:
    """The keypad of one firmware generation in one quirk profile."""
    if generation not in GENERATIONS:
        valid = ", ".join(GENERATIONS)
        raise ValueError(f"keypad manual must be one of {valid}, not {generation!r}")
    check_quirks(quirks)
    table, pdos = _table(factory_node_id, quirks), _pdos()
    eds_file, eds_date = "pkp-2600-si.eds", "02-05-2018"  # manual rev 1.1, 02/05/2018
    if generation == "1.5":
        table, pdos = _rev15_table(table, factory_node_id, quirks), _rev15_pdos(pdos)
        eds_file, eds_date = "pkp-2600-si-rev1.5.eds", "10-25-2021"  # rev 1.5, 25/10/2021
    return DeviceDescription(
        model=MODEL,
        kind=KIND,
        generation=generation,
        quirks=quirks,
        table=table,
        pdos=pdos,
        default_node_id=DEFAULT_NODE_ID,
        bitrates=BITRATES,
        nmt_aliases={0x00: NmtCommand.STOP},  # PKP §7 "old PKP sw compatibility", errata P12
        consumer_heartbeat=CONSUMER_HEARTBEAT if generation == "1.5" else None,
        face=FACE,
        led_fields=LED_FIELDS[generation],
        features=(GENERATION_2_FEATURES if generation == "1.5" else frozenset()) | {"j1939"},
        title="PKP-2600-SI keypad",
        edition=f"generation {GENERATIONS.index(generation) + 1} (manual rev {generation})",
        eds_file=eds_file,
        eds_date=eds_date,
        eds_defaults=_eds_led_mappings(generation),
    )


#: "j1939": the J1939 mode of both generations (devices/keypad_j1939.py, pkp-2600-si-j1939.md)
#: rev 1.5 (pkp-rev1.1-vs-rev1.5.md): SYNC (G3), node id at once (G1), backlight colour (G2)
GENERATION_2_FEATURES = frozenset({"sync", "node-id-at-once", "backlight-colour-pdo"})

#: PKP §2: two rows of six keys, 1-6 on top; an RGB LED under every key (PKP §11)
FACE = Face(
    keys=KEY_COUNT,
    grid=(tuple(range(1, 7)), tuple(range(7, 13))),
    led_colours=("red", "green", "blue"),
    led_keys=tuple(range(1, KEY_COUNT + 1)),
)

PKP_2600_SI = Model(
    name=MODEL,
    kind=KIND,
    aliases=("keypad",),
    generations=GENERATIONS,
    default_node_id=DEFAULT_NODE_ID,
    describe=describe_keypad,
    twin="blinkcan.twin.keypad:KeypadTwin",
    driver="blinkcan.host.keypad:Keypad",
)


__all__ = ["FACE", "KEY_COUNT", "MODEL", "PKP_2600_SI", "ObjectKind", "describe_keypad"]
