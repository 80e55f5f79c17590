"""PKP-3500-MT keypad: object table, PDO layouts and face, manual rev 1.3 (MT).

15 positions in 3 columns x 5 rows; keys 1 and 11 are pressable rotary encoders with 16-LED
rings; four 0-5 V analog inputs read as digital inputs too. § numbers are the manual's (MT);
where it contradicts itself the decision of ``spec/pkp-3500-mt-decisions.md`` (M1-M82) is
applied and cited. It is the PKP-2600-SI rev 1.5 firmware generation (SYNC, 1016h, 1011h, node id
at once): where the question is the same, the errata G decisions hold.
"""

from __future__ import annotations

from blinkcan.devices.common import (
    TIMER_MS_MAX,
    device_type,
    identity,
    identity_strings,
    model_id,
    pdo_mapping,
    producer_heartbeat_time,
)
from blinkcan.devices.keypad import (
    BITRATES,
    CONSUMER_HEARTBEAT,
    LEVEL_MAX,
    PROTOCOL_CANOPEN,
    PROTOCOL_J1939,
    SHOW_COMPLETE,
)
from blinkcan.devices.model import (
    DeviceDescription,
    Encoder,
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
from blinkcan.protocol.cob import RPDO1, RPDO2, RPDO3, RPDO4, TPDO1, TPDO2, TPDO3, TPDO4
from blinkcan.protocol.nmt import NmtCommand

MODEL = "pkp-3500-mt"
KIND = "keypad"
GENERATION = "1.3"  # manual rev 1.3, 16/05/2023
KEY_COUNT = 15
DEFAULT_NODE_ID = 0x15  # MT §3
VENDOR_ID = 0x000003E2  # MT §41
SERIAL_NUMBER = "FFFFFFFF"  # MT §57, an unprogrammed unit (M64)
#: MT §15/§16 (M27): 16 bits per colour; bit 0 (key 1) and bit 10 (key 11) are the encoders,
#: bit 15 is no key: these bits are ignored on write and read back 0
LED_BITS_PER_COLOUR = 16
LED_KEYS = tuple(k for k in range(1, KEY_COUNT + 1) if k not in (1, 11))
LED_KEY_MASK = sum(1 << (k - 1) for k in LED_KEYS)  # 7BFEh
RING_LEDS_PER_ENCODER = 16  # MT §2, §12: one turn = 16 ticks = one LED per tick (M26)
TOP_DEFAULT = 0x08  # MT §3
TOP_VALID = values(0x00, (0x02, 0x10))  # MT §19f/g, M39
DIRECTION_MAGNITUDE_MAX = 0x7F  # MT §12: bits 0-6 ticks, bit 7 counterclockwise (M37)
ANALOG_INPUTS = 4  # MT §1: IN0-IN3, 0-5 V
ANALOG_VOLTS_MAX = 5.0
ANALOG_COUNTS = 500  # MT §14: 10 mV per count, 0..01F4h (M44)
ANALOG_BYTE_MAX = 0xFF  # MT §24: 8-bit, 5 V = FFh (M45)
DIGITAL_THRESHOLD_COUNTS = 250  # M46: an input reads 1 from 2.5 V
ANALOG_PERIOD_UNIT_S = 0.01  # MT §25: 2006h counts 10 ms
ANALOG_PERIOD_DEFAULT = 0x08  # MT §3: 80 ms

_LEVEL = values((0, LEVEL_MAX))
_COLOUR = values((0x01, 0x09))  # MT §22c/d, M57
_FLAG = values(0, 1)
_EVENT_TIMER = values(0, (50, TIMER_MS_MAX))  # MT §50 (rev 1.2 "updated timer range"), M72
_SYNC_RPDO = values((0x00, 0xF0), 0xFE)  # M69, as G3
_SYNC_TPDO = values((0x01, 0xF0), 0xFE)  # M73

#: 2001h/2002h sub-indices as fields of the LED word (MT §20/§21): one 16-bit mask per colour,
#: laid out as the 215h/315h PDO bytes
LED_FIELDS = (LedField(1, "red", "red", 0, 16), LedField(2, "green", "green", 16, 16),
              LedField(3, "blue", "blue", 32, 16))


def _rpdo_parameter(index: int, cob_base: int, label: str, type_access: Access,
                    valid: object = None) -> ObjectDef:
    """1400h-1403h (MT §42-§45): COB-ID read-only; transmission type as M69/M70 decide."""
    n = index - 0x1400 + 1
    kw = {"valid": valid} if valid is not None else {}
    return record(index, f"rpdo{n}_parameter", label, (
        u32(1, f"rpdo{n}_cob_id", "COB-ID used by RPDO", Access.RO, NodeIdRelative(cob_base)),
        u8(2, f"rpdo{n}_transmission_type", "Transmission type", type_access, 0xFE, **kw),
    ))


def _tpdo_parameter(index: int, cob_base: int, label: str, type_valid: object = None
                    ) -> ObjectDef:
    """1800h-1802h (MT §50-§52): COB-ID read-only, type (1800h only writable), event timer."""
    n = index - 0x1800 + 1
    type_entry = (u8(2, f"tpdo{n}_transmission_type", "Transmission type", Access.RW, 0xFE,
                     valid=type_valid) if type_valid is not None else
                  u8(2, f"tpdo{n}_transmission_type", "Transmission type", Access.RO, 0xFE))
    return record(index, f"tpdo{n}_parameter", label, (
        u32(1, f"tpdo{n}_cob_id", "COB-ID used by TPDO", Access.RO, NodeIdRelative(cob_base)),
        type_entry,
        u16(5, f"tpdo{n}_event_timer", "Event timer", Access.RW, 0, valid=_EVENT_TIMER,
            stored=True, unit="ms"),  # M72: 0 = off, 50..65279 ms
    ))


def _led_masks(index: int, prefix: str, label: str, what: str) -> ObjectDef:
    """2001h LED on / 2002h LED blink (MT §20/§21): subs 01h-03h a colour each, 04h the rings."""
    return record(index, prefix, label, (
        *(u16(f.subindex, f"{prefix}_{f.suffix}", f"{what} {f.label}", Access.RW, 0,
              pdo_mappable=True) for f in LED_FIELDS),
        u32(4, f"{prefix}_rings", f"{what} encoder rings", Access.RW, 0, pdo_mappable=True),
    ))


def _encoder_entries() -> tuple[object, ...]:
    subs = []
    for encoder, (direction, ticks, top) in ((1, (2, 3, 6)), (2, (4, 5, 7))):
        subs += [
            u8(direction, f"encoder_{encoder}_direction", f"Encoder {encoder} direction counter",
               Access.RO, 0, pdo_mappable=True),  # MT §19b/d, M37, M41
            # MT §19c/e, M40: a read gives the live counter, a write stores the startup value
            u16(ticks, f"encoder_{encoder}_ticks", f"Encoder {encoder} tick counter",
                Access.RW, 0, stored=True, pdo_mappable=True),
            u8(top, f"encoder_{encoder}_top", f"TOP position encoder {encoder}", Access.RW,
               TOP_DEFAULT, valid=TOP_VALID, stored=True, pdo_mappable=True),  # §19f/g, M39
        ]
    return tuple(sorted(subs, key=lambda s: s.subindex))


def _table(factory_node_id: int, quirks: Quirks) -> ObjectTable:
    restore_ack = 0x43 if quirks == "firmware" else 0x60  # M8, as K3/G5
    return ObjectTable((
        device_type(0x000B0191),  # MT §34, M59
        # 1001h: "not yet implemented" (MT §35, M60): absent, so 0602 0000h
        *identity_strings("BlinkMarine", "V_00", "1.00"),  # MT §36-§38, M61: not reversed
        model_id("PKP3500MT"),  # MT §39, M62: the frames' 9 bytes, no hyphen
        record(0x1011, "restore_default_parameters", "Restore default parameters", (  # §40
            u32(1, "restore_all_parameters", "Restore all default parameters", Access.RW, 1,
                acknowledge=restore_ack),
        )),
        record(0x1016, "consumer_heartbeat", "Consumer heartbeat time", (  # MT §32, M65
            u32(1, "consumer_heartbeat_time", "Consumer heartbeat time", Access.RW,
                0x0001_0000, stored=True),
        )),
        producer_heartbeat_time(10),  # MT §33, M66
        identity(VENDOR_ID, (  # MT §41, M63
            u32(2, "product_code", "Product code", Access.RO, 0),
            u32(3, "revision_number", "Revision number", Access.RO, 0),
            u32(4, "serial_number", "Serial number", Access.RO, int(SERIAL_NUMBER, 16)),
        )),
        _rpdo_parameter(0x1400, RPDO1, "RPDO 1 communication parameter (key-LED on)",
                        Access.RW, _SYNC_RPDO),
        _rpdo_parameter(0x1401, RPDO2, "RPDO 2 communication parameter (key-LED blink)",
                        Access.RW, _SYNC_RPDO),
        _rpdo_parameter(0x1402, RPDO3, "RPDO 3 communication parameter (encoder LEDs)",
                        Access.RW, values(0xFE)),  # M70: only FEh
        _rpdo_parameter(0x1403, RPDO4, "RPDO 4 communication parameter (backlight)",
                        Access.RO),
        pdo_mapping(0x1600, "RPDO 1 mapping parameter", "rpdo1_mapping", tuple(
            mapping_value(0x2001, sub, 16) for sub in (1, 2, 3))),  # MT §46
        pdo_mapping(0x1601, "RPDO 2 mapping parameter", "rpdo2_mapping", tuple(
            mapping_value(0x2002, sub, 16) for sub in (1, 2, 3))),  # MT §47
        pdo_mapping(0x1602, "RPDO 3 mapping parameter", "rpdo3_mapping",
                 (mapping_value(0x2001, 4, 32),)),  # MT §48
        pdo_mapping(0x1603, "RPDO 4 mapping parameter", "rpdo4_mapping",
                 (mapping_value(0x2003, 2, 8), mapping_value(0x2003, 3, 8))),  # MT §49
        _tpdo_parameter(0x1800, TPDO1, "TPDO 1 communication parameter (key state)",
                        _SYNC_TPDO),
        _tpdo_parameter(0x1801, TPDO2, "TPDO 2 communication parameter (encoder 1)"),
        _tpdo_parameter(0x1802, TPDO3, "TPDO 3 communication parameter (encoder 2)"),
        record(0x1803, "tpdo4_parameter", "TPDO 4 communication parameter (analog inputs)", (
            u32(1, "tpdo4_cob_id", "COB-ID used by TPDO", Access.RO, NodeIdRelative(TPDO4)),
            # M12: reads the 2006h period byte (10 ms units), not a CiA 301 type
            u8(2, "tpdo4_transmission_type", "Analog period (10 ms)", Access.RO,
               ANALOG_PERIOD_DEFAULT),
        )),
        pdo_mapping(0x1A00, "TPDO 1 mapping parameter", "tpdo1_mapping",
                 (mapping_value(0x2000, 1, 16),)),  # MT §54, M13
        pdo_mapping(0x1A01, "TPDO 2 mapping parameter", "tpdo2_mapping", (  # MT §55, M42
            mapping_value(0x2000, 2, 8), mapping_value(0x2000, 3, 16),
            mapping_value(0x2000, 6, 8))),
        pdo_mapping(0x1A02, "TPDO 3 mapping parameter", "tpdo3_mapping", (  # MT §56, M42
            mapping_value(0x2000, 4, 8), mapping_value(0x2000, 5, 16),
            mapping_value(0x2000, 7, 8))),
        # M50 as revised (issue 17): the manual has no 1A03h and no object holds the 495h
        # values, but every CANopen master pairs 1803h with 1A03h (python-canopen's
        # RemoteNode.tpdo.read() reads it and aborts on 0602 0000h): 1A03h/00 reads 0, an
        # empty mapping; the 495h PDO is decoded from its layout below
        pdo_mapping(0x1A03, "TPDO 4 mapping parameter", "tpdo4_mapping", ()),
        record(0x2000, "digital_inputs", "Digital input module, keys states", (  # MT §19
            u16(1, "keys_pressed", "Keys pressed", Access.RO, 0, pdo_mappable=True),
            *_encoder_entries(),  # type: ignore[arg-type]
        )),
        _led_masks(0x2001, "led_on", "Digital output module, LED on", "LED on"),
        _led_masks(0x2002, "led_blink", "Digital output module, LED blink", "LED blink"),
        record(0x2003, "brightness", "Brightness level", (  # MT §22, M51-M58
            u8(1, "indicator_brightness", "Indicator LED brightness", Access.RW, LEVEL_MAX,
               valid=_LEVEL, power_on_from="startup_indicator_brightness"),
            u8(2, "backlight_brightness", "Backlight brightness", Access.RW, 0, valid=_LEVEL,
               power_on_from="startup_backlight_brightness", pdo_mappable=True),
            u8(3, "backlight_colour", "Backlight colour", Access.RW, 0x08, valid=_COLOUR,
               power_on_from="default_backlight_colour", pdo_mappable=True),
            u8(4, "default_backlight_colour", "Default backlight colour", Access.RW, 0x08,
               valid=_COLOUR, stored=True),
            u8(5, "startup_indicator_brightness", "Startup indicator LED brightness", Access.RW,
               LEVEL_MAX, valid=_LEVEL, stored=True),
            u8(6, "startup_backlight_brightness", "Startup backlight brightness", Access.RW, 0,
               valid=_LEVEL, stored=True),
        )),
        record(0x2004, "digital_input_levels", "Read digital input 8-bit", (  # MT §23, M46
            u8(1, "digital_inputs", "Digital inputs IN0-IN3", Access.RO, 0),
        )),
        record(0x2005, "analog_inputs", "Read analog input", tuple(  # MT §24, M45, M49
            u8(n + 1, f"analog_input_{n}", f"Analog input IN{n} (FFh at 5 V)", Access.RO, 0)
            for n in range(ANALOG_INPUTS)
        )),
        var(0x2006, "Set analog input message period", u8(0, "analog_period",
            "Analog input message period", Access.RW, ANALOG_PERIOD_DEFAULT,
            valid=values((0x08, 0xC8)), stored=True, unit="10 ms")),  # MT §25, M47
        var(0x2010, "Baud rate setting", u8(0, "baud_rate", "Baud rate", Access.RW, 0x04,
            valid=values((0, 7)), stored=True)),  # MT §26, B1
        var(0x2011, "Boot-up service", u8(0, "boot_up_service", "Boot-up service", Access.RW, 1,
            valid=_FLAG, stored=True)),  # MT §27
        var(0x2012, "Device active on startup", u8(0, "active_on_startup",
            "Device active on startup", Access.RW, 0, valid=_FLAG, stored=True)),  # MT §28
        var(0x2013, "CANopen node ID", u8(0, "node_id", "CANopen node ID", Access.RW,
            factory_node_id, valid=values((1, 0x7F)), stored=True)),  # MT §29, M7
        var(0x2014, "Startup LED show", u8(0, "startup_led_show", "Startup LED show", Access.RW,
            SHOW_COMPLETE, valid=values((0, 2)), stored=True)),  # MT §30
        record(0x20FF, "can_protocol_switch", "Set CAN protocol", (  # MT §58, M14, M82
            u16(1, "can_protocol", "CAN protocol", Access.RW, PROTOCOL_CANOPEN,
                valid=values(PROTOCOL_CANOPEN, PROTOCOL_J1939), stored=True),
        )),
        var(0x2100, "DEMO mode", u8(0, "demo_mode", "DEMO mode", Access.RW, 0, valid=_FLAG,
            stored=True)),  # MT §31, M75
        var(0x2200, "Serial number string", text(0, "serial_number_string",
            "Serial number string", SERIAL_NUMBER)),  # MT §57, M64
    ))


def _led_pdo(name: str, label: str, cob_base: int) -> PdoLayout:
    """215h/315h (MT §15/§16, M27): 16 bits per colour, the encoder and bit-15 holes included."""
    return PdoLayout(name, label, cob_base, Direction.RX, 8, tuple(
        PdoSignal(colour, f"{label} {colour}", shift * LED_BITS_PER_COLOUR, LED_BITS_PER_COLOUR,
                  f"{name}_{colour}", item="LED")
        for shift, colour in enumerate(("red", "green", "blue"))
    ), min_length=6)  # M20: RPDOs act with DLC >= the bytes they use


def _encoder_pdo(encoder: int, cob_base: int) -> PdoLayout:
    """295h/395h (MT §12/§13, M33-M38): direction counter, tick counter LSB first, TOP. The
    device sends 8 bytes (M20); 1A01h/1A02h map bytes 0-3 (M42), so a frame of 4 bytes (what a
    CANopen stack configured from the EDS sends) carries everything and is taken."""
    return PdoLayout(f"encoder_{encoder}", f"Encoder {encoder} state", cob_base, Direction.TX,
                     8, (
                         PdoSignal("direction", "Ticks since the last report", 0, 8,
                                   f"encoder_{encoder}_direction", sign_magnitude=True),
                         PdoSignal("ticks", "Tick counter", 8, 16, f"encoder_{encoder}_ticks"),
                         PdoSignal("top", "TOP position", 24, 8, f"encoder_{encoder}_top"),
                     ), min_length=4)


def _pdos() -> tuple[PdoLayout, ...]:
    return (
        PdoLayout("key_state", "Keys state", TPDO1, Direction.TX, 5, (  # MT §11, M13, M31
            PdoSignal("keys", "Keys pressed", 0, KEY_COUNT, "keys_pressed", item="key"),
            PdoSignal("tick", "Tick timer", 32, 8, None),
        ), min_length=2, period="tpdo1_event_timer"),  # MT §50: 1800h/05 event timer
        _encoder_pdo(1, TPDO2),
        _encoder_pdo(2, TPDO3),
        PdoLayout("analog_inputs", "Analog inputs", TPDO4, Direction.TX, 8, tuple(  # MT §14
            PdoSignal(f"in{n}", f"IN{n}", 16 * n, 16, None, scale=0.01, unit="V")
            for n in range(ANALOG_INPUTS)
        ), period="analog_period"),  # MT §14: every 2006h x 10 ms
        _led_pdo("led_on", "Set key-LED on", RPDO1),
        _led_pdo("led_blink", "Set key-LED blink", RPDO2),
        PdoLayout("ring_leds", "Set encoder LEDs on", RPDO3, Direction.RX, 8, (  # MT §17, M29
            PdoSignal("rings", "Encoder ring LEDs", 0, 2 * RING_LEDS_PER_ENCODER, "led_on_rings",
                      item="ring LED"),
        ), min_length=4),
        PdoLayout("backlight_brightness", "Backlight setting", RPDO4, Direction.RX, 8, (
            PdoSignal("level", "Brightness level", 0, 8, "backlight_brightness"),
            PdoSignal("colour", "Colour (out of 01h-09h: the colour in use)", 8, 8, None),
        ), min_length=1),  # MT §18, M51-M54
    )


#: MT §2 (M25): right column 1-5, middle 6-10, left 11-15, seen from the front
FACE = Face(
    keys=KEY_COUNT,
    grid=tuple((11 + row, 6 + row, 1 + row) for row in range(5)),
    led_colours=("red", "green", "blue"),
    led_keys=LED_KEYS,
    encoders=(
        Encoder(1, 1, tuple(range(1, 17)), "encoder_1"),  # M26: LED 1 at six o'clock
        Encoder(2, 11, tuple(range(17, 33)), "encoder_2"),
    ),
    analog_inputs=ANALOG_INPUTS,
    analog_volts_max=ANALOG_VOLTS_MAX,
    digital_inputs=ANALOG_INPUTS,  # M46: the same four inputs, read against 2.5 V
)


def describe_pkp3500(
    generation: str = GENERATION,
    quirks: Quirks = "firmware",
    factory_node_id: int = DEFAULT_NODE_ID,
) -> DeviceDescription:
    """The PKP-3500-MT in one quirk profile (one firmware generation: manual rev 1.3)."""
    if generation != GENERATION:
        raise ValueError(f"{MODEL} generations are {GENERATION}, not {generation!r}")
    check_quirks(quirks)
    return DeviceDescription(
        model=MODEL,
        kind=KIND,
        generation=GENERATION,
        quirks=quirks,
        table=_table(factory_node_id, quirks),
        pdos=_pdos(),
        default_node_id=DEFAULT_NODE_ID,
        bitrates=BITRATES,  # MT §26: the PKP-2600-SI's codes (B1)
        nmt_aliases={0x00: NmtCommand.STOP},  # MT §7, M22
        consumer_heartbeat=CONSUMER_HEARTBEAT,  # MT §32, M65: as the PKP-2600-SI rev 1.5 (G4)
        face=FACE,
        title="PKP-3500-MT keypad",
        edition=f"manual rev {GENERATION}",
        eds_file="pkp-3500-mt.eds",
        eds_date="05-16-2023",  # manual rev 1.3, 16/05/2023
        led_fields=LED_FIELDS,
        features=frozenset({"sync", "node-id-at-once", "backlight-colour-pdo"}),
    )


PKP_3500_MT = Model(
    name=MODEL,
    kind=KIND,
    aliases=("pkp3500mt", "pkp-3500"),
    generations=(GENERATION,),
    default_node_id=DEFAULT_NODE_ID,
    describe=describe_pkp3500,
    twin="blinkcan.twin.pkp3500:Pkp3500Twin",
    driver="blinkcan.host.pkp3500:Pkp3500Keypad",
)
