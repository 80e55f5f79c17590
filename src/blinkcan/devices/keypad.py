"""PKP-2600-SI keypad: object table and PDO layouts, manual rev 1.1 (the seed manual).

Every object the manual documents is here once; § numbers are the manual's. Where the manual
contradicts itself the errata.md decision is applied and cited.
"""

from __future__ import annotations

from blinkcan.devices.common import (
    TIMER_MS_MAX,
    device_type,
    identity,
    identity_strings,
    model_id,
    producer_heartbeat_time,
)
from blinkcan.devices.model import DeviceDescription, Quirks, check_quirks
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
GENERATIONS = ("1.1",)
KEY_COUNT = 12
DEFAULT_NODE_ID = 0x15  # PKP §3
VENDOR_ID = 0x000003E2  # PKP §32
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
_LED_MASK = values((0, (1 << KEY_COUNT) - 1))
_TIMER = values(0, (10, TIMER_MS_MAX))  # errata P1/P2: 0 = off, 10..65279 ms


def _rpdo_parameter(index: int, cob_base: int, label: str) -> ObjectDef:
    """1400h-1403h (PKP §33-§36): COB-ID and transmission type FEh, read-only in rev 1.1."""
    n = index - 0x1400 + 1
    return record(index, f"rpdo{n}_parameter", label, (
        u32(1, f"rpdo{n}_cob_id", "COB-ID used by RPDO", Access.RO, NodeIdRelative(cob_base)),
        u8(2, f"rpdo{n}_transmission_type", "Transmission type", Access.RO, 0xFE),
    ))


def _mapping(index: int, label: str, prefix: str, targets: tuple[int, ...]) -> ObjectDef:
    """1600h-1603h, 1A00h: the mapping entries exactly as the manual prints them (errata P7)."""
    return record(index, prefix, label, tuple(
        u32(i, f"{prefix}_entry_{i}", f"PDO mapping entry {i}", Access.RO, target)
        for i, target in enumerate(targets, start=1)
    ))


def _led_masks(index: int, prefix: str, label: str, what: str) -> ObjectDef:
    """2001h LED on / 2002h LED blink (PKP §16, §17): one 12-bit mask per colour."""
    return record(index, prefix, label, tuple(
        u16(sub, f"{prefix}_{colour}", f"{what} {colour}", Access.RW, 0, valid=_LED_MASK,
            pdo_mappable=True)
        for sub, colour in ((1, "red"), (2, "green"), (3, "blue"))
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
        _mapping(0x1600, "RPDO 1 mapping parameter", "rpdo1_mapping", (
            mapping_value(0x2001, 1, 8), mapping_value(0x2001, 2, 8), mapping_value(0x2001, 3, 8),
        )),
        _mapping(0x1601, "RPDO 2 mapping parameter", "rpdo2_mapping", (
            mapping_value(0x2002, 1, 8), mapping_value(0x2002, 2, 8), mapping_value(0x2002, 3, 8),
        )),
        _mapping(0x1602, "RPDO 3 mapping parameter", "rpdo3_mapping",  # errata P16
                 (mapping_value(0x2003, 1, 8),)),
        _mapping(0x1603, "RPDO 4 mapping parameter", "rpdo4_mapping",  # errata P17
                 (mapping_value(0x2003, 2, 8),)),
        record(0x1800, "tpdo1_parameter", "TPDO 1 communication parameter (key state)", (
            u32(1, "tpdo1_cob_id", "COB-ID used by TPDO", Access.RO, NodeIdRelative(TPDO1)),
            u8(2, "tpdo1_transmission_type", "Transmission type", Access.RO, 0xFE),
            # PKP §41b, errata P2/P3: ms, 0 = off, read back with 4Bh
            u16(5, "tpdo1_event_timer", "Event timer", Access.RW, 0, valid=_TIMER, stored=True,
                unit="ms"),
        )),
        _mapping(0x1A00, "TPDO 1 mapping parameter", "tpdo1_mapping",  # PKP §42, errata P8
                 (mapping_value(0x2000, 1, 16),)),
        record(0x2000, "digital_inputs", "Digital input module, keys states", (  # PKP §15
            u16(1, "keys_pressed", "Keys pressed", Access.RO, 0, pdo_mappable=True),
        )),
        _led_masks(0x2001, "led_on", "Digital output module, LED on", "LED on"),
        _led_masks(0x2002, "led_blink", "Digital output module, LED blink", "LED blink"),
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
    """200h/300h + id (PKP §11/§12, errata P7/P13): red 0-11, green 12-23, blue 24-35."""
    return PdoLayout(name, label, cob_base, Direction.RX, 8, tuple(
        PdoSignal(colour, f"{label} {colour}", shift * LED_BITS_PER_COLOUR, LED_BITS_PER_COLOUR,
                  f"{prefix}_{colour}", item="LED")
        for shift, colour in enumerate(("red", "green", "blue"))
    ), min_length=5)


def _pdos() -> tuple[PdoLayout, ...]:
    return (
        PdoLayout("key_state", "Keys state", TPDO1, Direction.TX, 5, (  # PKP §10, errata P8
            PdoSignal("keys", "Keys pressed", 0, KEY_COUNT, "keys_pressed", item="key"),
            PdoSignal("tick", "Tick timer", 32, 8, None),
        ), min_length=2),
        _led_pdo("led_on", "Set LED on", RPDO1, "led_on"),
        _led_pdo("led_blink", "Set LED blink", RPDO2, "led_blink"),
        PdoLayout("indicator_brightness", "Indicator LEDs brightness", RPDO3, Direction.RX, 8, (
            PdoSignal("level", "Brightness level", 0, 8, "indicator_brightness"),
        ), min_length=1),  # PKP §13, errata P14/P15
        PdoLayout("backlight_brightness", "Backlight brightness", RPDO4, Direction.RX, 8, (
            PdoSignal("level", "Brightness level", 0, 8, "backlight_brightness"),
        ), min_length=1),  # PKP §14, errata P14/P15
    )


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
    return DeviceDescription(
        model=MODEL,
        kind=KIND,
        generation=generation,
        quirks=quirks,
        table=_table(factory_node_id, quirks),
        pdos=_pdos(),
        default_node_id=DEFAULT_NODE_ID,
        bitrates=BITRATES,
        nmt_aliases={0x00: NmtCommand.STOP},  # PKP §7 "old PKP sw compatibility", errata P12
    )


__all__ = ["KEY_COUNT", "MODEL", "ObjectKind", "describe_keypad"]
