"""Keybox 13-output power module: object table and PDO layouts (`keybox-canopen-manual.txt`).

§ numbers are the manual's (KBX). Where it contradicts itself the errata.md decision is applied
and cited. Pin behaviour (OFF/HIGH/FAULT, fuses, PWM) lives in ``twin/keybox_outputs.py``.
"""

from __future__ import annotations

from blinkcan.devices.common import (
    TIMER_MS_MAX,
    ConsumerHeartbeat,
    device_type,
    identity,
    identity_strings,
    model_id,
    producer_heartbeat_time,
)
from blinkcan.devices.model import DeviceDescription, Face, Model, Quirks, check_quirks
from blinkcan.devices.objects import (
    Access,
    NodeIdRelative,
    ObjectDef,
    ObjectTable,
    mapping_value,
    record,
    u8,
    u16,
    u32,
    values,
    var,
)
from blinkcan.devices.pdo import Direction, PdoLayout, PdoSignal
from blinkcan.protocol.cob import RPDO1, TPDO1

MODEL = "keybox"
KIND = "keybox"
GENERATION = "1.0"  # manual rev 1.0 (KBX §42)
PIN_COUNT = 13
PWM_PINS = (12, 13)  # KBX §5: pins 12 and 13 are MOSFET outputs with PWM
LOW_SIDE_CAPABLE = (2, 5)  # KBX §5/§6: Ch2 and Ch5 may be built as low-side drivers (K22)
DEFAULT_NODE_ID = 0x0C  # KBX §10
VENDOR_ID = 0x000003E2  # KBX §37
#: KBX §28, errata K8: 0 = off, 10..65279 ms; any node 01h-7Fh
CONSUMER_HEARTBEAT = ConsumerHeartbeat(values(0, (10, TIMER_MS_MAX)))
PIN_MASK = (1 << PIN_COUNT) - 1
PWM_LEVEL_MAX = 0x0A  # KBX §22: 00h-0Ah = 0-100 % in 10 % steps
FAULT_PERIOD_UNIT_S = 0.01  # errata K4: 2012h counts 10 ms

#: 2001h pin state codes (KBX §19)
PIN_OFF, PIN_HIGH, PIN_RESET, PIN_FAULT = 0x00, 0x01, 0x02, 0x03
#: what the driver, the decoder, the panel and the twin's snapshot call a pin state
PIN_STATE_NAMES = {PIN_OFF: "off", PIN_HIGH: "high", PIN_FAULT: "fault"}
#: 2009h (KBX §22, errata K16): byte 0 a mask of the PWM pins (bit 0 = pin 12, bit 1 = pin 13),
#: byte 1 the duty level 00h-0Ah
PWM_BITS = {pin: 1 << i for i, pin in enumerate(PWM_PINS)}
PWM_MASK = sum(PWM_BITS.values())


def commanded_outputs(off: int, high: int) -> tuple[int, int]:
    """(pins switched OFF, pins switched HIGH) by an outputs PDO's two masks, or an OFF and a
    HIGH mask written together: KBX §17, errata K12: OFF wins where a pin is in both."""
    return off, high & ~off


def pwm_register(mask: int, level: int) -> int:
    """The 2009h value of a PWM-pin mask and a duty level (KBX §22)."""
    return mask | level << 8


def split_pwm_register(value: int) -> tuple[int, int]:
    """(PWM-pin mask, duty level) of a 2009h value (KBX §22)."""
    return value & 0xFF, value >> 8

#: 2010h codes (KBX §23, errata B1)
BITRATES = {0x00: 125_000, 0x01: 250_000, 0x02: 500_000}

_FLAG = values(0, 1)
_PINS = values((0, PIN_MASK))


def _pin_states() -> ObjectDef:
    """2001h (KBX §19, errata K1/K2): one pin per sub-index, 00h OFF, 01h HIGH, 02h RESET
    (write only), 03h FAULT (read only): writes 00h-02h."""
    return record(0x2001, "pin_state", "Single pin state", tuple(
        u8(pin, f"pin_{pin}_state", f"Pin {pin} state", Access.RW, PIN_OFF,
           valid=values((PIN_OFF, PIN_RESET)))
        for pin in range(1, PIN_COUNT + 1)
    ))


def _table(factory_node_id: int, quirks: Quirks) -> ObjectTable:
    # errata K3 (Q): the firmware acknowledges the 1011h "load" with 43h, CiA 301 with 60h
    restore_ack = 0x43 if quirks == "firmware" else 0x60
    return ObjectTable((
        device_type(0x00030191),  # KBX §30, errata B5
        # 1001h: "not yet implemented in the device" (KBX §31): absent, so 0602 0000h.
        *identity_strings("BlinkMarine", "V_02", "1.00"),  # KBX §32-§34
        model_id("Keybox3"),  # KBX §35
        record(0x1011, "restore_default_parameters", "Restore default parameters", (  # KBX §36
            # CiA 301: reads 1 ("restores on command"); a write of "load" restores (K3, K18)
            u32(1, "restore_all_parameters", "Restore all default parameters", Access.RW, 1,
                acknowledge=restore_ack),
        )),
        record(0x1016, "consumer_heartbeat", "Consumer heartbeat time", (  # KBX §28, errata K8
            # bits 0-15 time in ms (0 = off, 10..65279), bits 16-23 node 01h-7Fh, 24-31 zero
            u32(1, "consumer_heartbeat_time", "Consumer heartbeat time", Access.RW, 0x0001_0000,
                stored=True),
        )),
        producer_heartbeat_time(1),  # KBX §29, errata K17: 0 = off, 1..65279 ms
        identity(VENDOR_ID),  # KBX §37: sub 00h = 01h
        record(0x1400, "rpdo1_parameter", "RPDO 1 communication parameter (outputs)", (
            u32(1, "rpdo1_cob_id", "COB-ID used by RPDO", Access.RO, NodeIdRelative(RPDO1)),
            u8(2, "rpdo1_transmission_type", "Transmission type", Access.RO, 0xFE),
        )),  # KBX §38
        record(0x1600, "rpdo1_mapping", "RPDO 1 mapping parameter", (  # KBX §39, errata K7
            u32(1, "rpdo1_mapping_entry_1", "PDO mapping entry 1", Access.RO,
                mapping_value(0x2008, 1, 16)),
            u32(2, "rpdo1_mapping_entry_2", "PDO mapping entry 2", Access.RO,
                mapping_value(0x2008, 2, 16)),
        )),
        record(0x1800, "tpdo1_parameter", "TPDO 1 communication parameter (faults)", (
            u32(1, "tpdo1_cob_id", "COB-ID used by TPDO", Access.RO, NodeIdRelative(TPDO1)),
            u8(2, "tpdo1_transmission_type", "Transmission type", Access.RO, 0xFE),
        )),  # KBX §40, errata B3: sub 00h-02h only
        record(0x1A00, "tpdo1_mapping", "TPDO 1 mapping parameter", (  # KBX §41
            u32(1, "tpdo1_mapping_entry_1", "PDO mapping entry 1", Access.RO,
                mapping_value(0x2008, 3, 16)),
        )),
        _pin_states(),
        record(0x2003, "digital_input", "Read digital input", (  # KBX §20, errata K9/K21
            u16(1, "input_levels", "Input levels of pins 1-13", Access.RO, 0),
        )),
        record(0x2008, "output_state", "Output state", (  # KBX §21, errata K5/K15/K20
            u16(1, "output_off_mask", "Outputs OFF", Access.RW, PIN_MASK, valid=_PINS,
                pdo_mappable=True),
            u16(2, "output_high_mask", "Outputs HIGH", Access.RW, 0, valid=_PINS,
                pdo_mappable=True),
            u16(3, "output_fault_mask", "Outputs FAULT", Access.RO, 0, pdo_mappable=True),
        )),
        record(0x2009, "pwm_state", "PWM state", (  # KBX §22, errata K16
            # byte 0: bit 0 = pin 12, bit 1 = pin 13; byte 1: duty level 00h-0Ah
            u16(1, "pwm", "Output PWM", Access.RW, 0),
        )),
        var(0x2010, "Baud rate setting", u8(0, "baud_rate", "Baud rate", Access.RW, 0x00,
            valid=values((0, 2)), stored=True)),  # KBX §23, errata B1
        var(0x2011, "Set node ID", u8(0, "node_id", "CANopen node ID", Access.RW,
            factory_node_id, valid=values((1, 0x7F)), stored=True)),  # KBX §24, errata K6
        var(0x2012, "Set periodic messages", u16(0, "fault_period", "Periodic fault message",
            Access.RW, 0, valid=values((0, TIMER_MS_MAX)), stored=True,
            unit="10 ms")),  # KBX §25, errata K4
        var(0x2013, "Device active on startup", u8(0, "active_on_startup",
            "Device active on startup", Access.RW, 0, valid=_FLAG, stored=True)),  # KBX §26
        var(0x2015, "Boot-up service", u8(0, "boot_up_service", "Boot-up service", Access.RW, 1,
            valid=_FLAG, stored=True)),  # KBX §27, errata K13
    ))


def _pdos() -> tuple[PdoLayout, ...]:
    return (
        PdoLayout("outputs", "Set output (OFF and HIGH)", RPDO1, Direction.RX, 8, (  # KBX §17
            PdoSignal("off", "Set OFF", 0, PIN_COUNT, "output_off_mask", item="pin"),
            PdoSignal("high", "Set HIGH", 16, PIN_COUNT, "output_high_mask", item="pin"),
        ), min_length=4),
        PdoLayout("faults", "Fault message", TPDO1, Direction.TX, 8, (  # KBX §18
            PdoSignal("faults", "Pins in FAULT", 0, PIN_COUNT, "output_fault_mask", item="pin"),
        ), min_length=2, period="fault_period"),  # KBX §25: periodic fault message
    )


#: KBX §5/§6: 13 outputs, PWM on 12 and 13, Ch2 and Ch5 may be built low-side
FACE = Face(pins=PIN_COUNT, pwm_pins=PWM_PINS, pwm_duty_max=PWM_LEVEL_MAX,
            low_side_capable=LOW_SIDE_CAPABLE)


def describe_keybox(quirks: Quirks = "firmware", factory_node_id: int = DEFAULT_NODE_ID
                    ) -> DeviceDescription:
    check_quirks(quirks)
    return DeviceDescription(
        model=MODEL,
        kind=KIND,
        generation=GENERATION,
        quirks=quirks,
        table=_table(factory_node_id, quirks),
        pdos=_pdos(),
        default_node_id=DEFAULT_NODE_ID,
        bitrates=BITRATES,
        consumer_heartbeat=CONSUMER_HEARTBEAT,
        face=FACE,
        title="Keybox",
        edition=f"manual rev {GENERATION}",
        eds_file="keybox.eds",
        eds_date="04-18-2019",  # KBX §42: manual rev 1.0, 18/04/2019
    )


def _describe(generation: str, quirks: Quirks, factory_node_id: int) -> DeviceDescription:
    return describe_keybox(quirks, factory_node_id)


KEYBOX = Model(
    name=MODEL,
    kind=KIND,
    aliases=(),
    generations=(GENERATION,),
    default_node_id=DEFAULT_NODE_ID,
    describe=_describe,
    twin="blinkcan.twin.keybox:KeyboxTwin",
    driver="blinkcan.host.keybox:Keybox",
)
