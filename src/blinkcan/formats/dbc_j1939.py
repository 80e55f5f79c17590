"""The DBC of a PKP-2600-SI in J1939 mode, built with cantools from ``devices/keypad_j1939.py``.

A J1939 DBC as Vector tools and cantools read it: ``ProtocolType "J1939"``, each message's
``VFrameFormat`` ``J1939PG`` (cantools writes it for ``protocol="j1939"``), 29-bit identifiers
with the keypad's source address and the controller's. PGN EF00h carries a command byte (byte 2)
that selects the layout, so both directions are multiplexed messages: one signal set per
command, named ``<command>_<field>``.

From the keypad, the LED acknowledge (§19, ``00 <state> <LED> <colour> <secondary> FF FF FF``)
shares the identifier of the key messages (``04 1B <command> ...``) but has no ``04 1B`` header.
Byte 0 tells the two apart (04h: a header, so a command byte follows; 00h: an acknowledge), so
that message multiplexes twice (DBC extended multiplexing, ``SG_MUL_VAL_``): ``frame`` (byte 0)
selects the acknowledge's signals or ``command`` (byte 2), which selects the message's. A tool
without extended multiplexing still reads ``frame`` and tells them apart.

What a DBC cannot express (said in the messages' comments and the README): a DBC message has one
29-bit identifier, so frames with another priority, destination (6Eh moves the key messages'),
sender (a command from another address than the controller's, or to the global address FFh,
which the keypad also takes, J-2) or keypad address are not in it (export one per address); the
software revision's 4 ASCII bytes are one integer (a DBC signal has no text type).
"""

from __future__ import annotations

import os
from collections import OrderedDict

import cantools.database as cdb
from cantools.database.can import Message, Signal
from cantools.database.can.formats.dbc import (
    DbcAttribute,
    DbcAttributeDefinition,
    DbcSpecifics,
)

from blinkcan.devices.keypad import FACE
from blinkcan.devices.keypad_j1939 import (
    COLOUR_CODES,
    COMMANDS,
    DEFAULT_ADDRESS,
    DEFAULT_HOST_ADDRESS,
    HEADER,
    HEARTBEAT,
    KEY_MESSAGE,
    NIBBLE_BLINK,
    PGN_COMMAND,
    PGN_LEDS_COLOUR_1,
    PGN_LEDS_COLOUR_2,
    PRIORITY,
    SOFTWARE_REVISION_REPLY,
    LedState,
    led_acknowledge,
)
from blinkcan.formats.atomic import write_atomically
from blinkcan.protocol.j1939 import GLOBAL_ADDRESS, NAME_FIELDS, PGN_ADDRESS_CLAIMED, compose_id

_COMMAND_BYTE = 16  # bit position of byte 2
#: byte 0 of a frame from the keypad: the 04h of the ``04 1B`` header (§4), or the 00h that
#: starts an LED acknowledge (§19)
_HEADER_FIRST, _ACKNOWLEDGE_FIRST = HEADER[0], led_acknowledge(0, 0, 0, 0)[0]
_STATES = {int(state): state.name.lower() for state in LedState}  # §7a


def _value(name: str, start: int, length: int, receivers: list[str], comment: str,
           choices: dict[int, str] | None = None, multiplexer_id: int | None = None,
           multiplexer: str = "command") -> Signal:
    return Signal(name, start, length, byte_order="little_endian", is_signed=False,
                  comment=comment, receivers=receivers,
                  multiplexer_ids=None if multiplexer_id is None else [multiplexer_id],
                  multiplexer_signal=None if multiplexer_id is None else multiplexer,
                  conversion=cdb.conversion.NamedSignalConversion(
                      1, 0, OrderedDict(choices), is_float=False) if choices else None)


def _header(receivers: list[str]) -> Signal:
    """Bytes 0-1, ``04 1B`` (§4): 1B04h read little-endian."""
    return Signal("header", 0, 16, byte_order="little_endian", is_signed=False,
                  receivers=receivers, comment="04 1B (§4): 0x1B04", raw_initial=0x1B04)


def _selector(codes: dict[int, str], receivers: list[str], within: str | None = None
              ) -> Signal:
    """Byte 2, the command; ``within``: itself multiplexed by byte 0 (``frame`` = 04h)."""
    return Signal("command", _COMMAND_BYTE, 8, byte_order="little_endian", is_signed=False,
                  is_multiplexer=True, receivers=receivers, comment="Command byte (§4)",
                  multiplexer_ids=None if within is None else [_HEADER_FIRST],
                  multiplexer_signal=within,
                  conversion=cdb.conversion.NamedSignalConversion(
                      1, 0, OrderedDict(codes), is_float=False))


def _frame_kind(receivers: list[str]) -> Signal:
    """Byte 0 of a frame from the keypad: 04h, the header of a message with a command byte;
    00h, an LED acknowledge (§19), which has none."""
    return Signal("frame", 0, 8, byte_order="little_endian", is_signed=False,
                  is_multiplexer=True, receivers=receivers,
                  comment="04h: 04 1B header, a command byte follows (§4); 00h: LED "
                          "acknowledge (§19)",
                  conversion=cdb.conversion.NamedSignalConversion(1, 0, OrderedDict({
                      _HEADER_FIRST: "message", _ACKNOWLEDGE_FIRST: "led_acknowledge"}),
                      is_float=False))


def _acknowledge(receivers: list[str]) -> list[Signal]:
    """§19: ``00 <state> <LED number> <primary colour> <secondary colour> FF FF FF``."""
    fields = (("state", "LED state (§7a codes)", _STATES), ("led", "LED number", None),
              ("colour", "Primary colour", COLOUR_CODES),
              ("secondary", "Secondary colour", COLOUR_CODES))
    return [_value(f"led_acknowledge_{name}", 8 * (offset + 1), 8, receivers,
                   f"LED acknowledge (§19): {label}", choices, _ACKNOWLEDGE_FIRST, "frame")
            for offset, (name, label, choices) in enumerate(fields)]


def _commands(keypad: str, controller: str, address: int, host: int) -> Message:
    """To the keypad on PGN EF00h: every command of the table, multiplexed by its code."""
    signals = [_header([keypad]), _selector({c.code: c.name for c in COMMANDS}, [keypad])]
    for command in COMMANDS:
        for offset, field in enumerate(command.fields, start=3):
            choices = COLOUR_CODES if field.name in ("colour", "secondary") else \
                _STATES if command.name == "single_led" and field.name == "state" else None
            signals.append(_value(f"{command.name}_{field.name}", offset * 8, 8, [keypad],
                                  f"{command.label} {command.section}: {field.label}",
                                  choices, command.code))
    return Message(compose_id(PGN_COMMAND, host, address, PRIORITY),
                   f"{keypad}_COMMAND", 8, signals, senders=[controller], protocol="j1939",
                   is_extended_frame=True,
                   comment=f"Commands to the keypad (§4) from address {host:02X}h; from "
                           "another sender, or to the global address FFh, they have another "
                           "identifier, not in this DBC")


def _messages(keypad: str, controller: str, address: int) -> Message:
    """From the keypad on PGN EF00h to all: key state, software revision, heartbeat, and the
    LED acknowledge, told apart by byte 0 (see the module docstring)."""
    receivers = [controller]
    signals = [
        _frame_kind(receivers),
        Signal("header_1b", 8, 8, byte_order="little_endian", is_signed=False,
               receivers=receivers, comment="1Bh, byte 1 of the 04 1B header (§4)",
               multiplexer_ids=[_HEADER_FIRST], multiplexer_signal="frame",
               raw_initial=HEADER[1]),
        _selector({KEY_MESSAGE: "key", SOFTWARE_REVISION_REPLY: "software_revision",
                   HEARTBEAT: "heartbeat"}, receivers, within="frame"),
        *_acknowledge(receivers),
        _value("key_number", 24, 8, receivers, "Key (§6)", None, KEY_MESSAGE),
        _value("key_state", 32, 8, receivers, "Key state (§6)", {0: "released", 1: "pressed"},
               KEY_MESSAGE),
        _value("key_identifier", 40, 8, receivers, "Keypad identifier (§16)", None,
               KEY_MESSAGE),
        _value("software_revision", 24, 32, receivers, "4 ASCII bytes, e.g. V2.6 (§11)", None,
               SOFTWARE_REVISION_REPLY),
        _value("heartbeat_counter", 24, 8, receivers, "Counter, +1 per message (§18, J-6)",
               None, HEARTBEAT),
        *(_value(f"heartbeat_key_{key}", 32 + key - 1, 1, receivers,
                 f"Key {key} held (§18)", None, HEARTBEAT) for key in range(1, FACE.keys + 1)),
        _value("heartbeat_identifier", 56, 8, receivers, "Keypad identifier (§18)", None,
               HEARTBEAT),
    ]
    return Message(compose_id(PGN_COMMAND, address, GLOBAL_ADDRESS, PRIORITY),
                   f"{keypad}_MESSAGE", 8, signals, senders=[keypad], protocol="j1939",
                   is_extended_frame=True,
                   comment="Messages from the keypad (§6, §11, §18) and LED acknowledge (§19) "
                           "to the global address; sent to another destination (6Eh) they "
                           "have another identifier, not in this DBC. software_revision: 4 "
                           "ASCII bytes read as one little-endian integer")


def _leds(pgn: int, which: int, keypad: str, controller: str, address: int, host: int
          ) -> Message:
    choices = {**COLOUR_CODES, NIBBLE_BLINK: "blink"}
    signals = [_value(f"led_{key}", 4 * (key - 1), 4, [keypad],
                      f"LED {key}, colour {which} (§7b)", choices)
               for key in range(1, FACE.keys + 1)]
    return Message(compose_id(pgn, host, address, PRIORITY), f"{keypad}_LEDS_COLOUR_{which}", 8,
                   signals, senders=[controller], protocol="j1939", is_extended_frame=True,
                   comment=f"Multiple LEDs, colour {which} (§7b, LED management mode 02h)")


def _address_claim(keypad: str, controller: str, address: int) -> Message:
    signals = [_value(f"name_{name}", shift, width, [controller], f"NAME: {name} (J1939-81)")
               for name, shift, width in NAME_FIELDS]
    return Message(compose_id(PGN_ADDRESS_CLAIMED, address, GLOBAL_ADDRESS, PRIORITY),
                   f"{keypad}_ADDRESS_CLAIMED", 8, signals, senders=[keypad], protocol="j1939",
                   is_extended_frame=True, comment="Address claim (§20)")


def _dbc_specifics() -> DbcSpecifics:
    protocol = DbcAttributeDefinition("ProtocolType", default_value="", kind=None,
                                      type_name="STRING")
    frame_format = DbcAttributeDefinition(
        "VFrameFormat", default_value="StandardCAN", kind="BO_", type_name="ENUM",
        choices=["StandardCAN", "ExtendedCAN", "reserved", "J1939PG"])
    return DbcSpecifics(
        attributes=OrderedDict(ProtocolType=DbcAttribute("J1939", protocol)),
        attribute_definitions=OrderedDict(ProtocolType=protocol, VFrameFormat=frame_format))


def database(address: int = DEFAULT_ADDRESS, host: int = DEFAULT_HOST_ADDRESS) -> cdb.Database:
    """The keypad at J1939 ``address``, commanded from ``host``."""
    keypad, controller = f"KEYPAD_{address:02X}", "CONTROLLER"
    messages = [
        _commands(keypad, controller, address, host),
        _messages(keypad, controller, address),
        _leds(PGN_LEDS_COLOUR_1, 1, keypad, controller, address, host),
        _leds(PGN_LEDS_COLOUR_2, 2, keypad, controller, address, host),
        _address_claim(keypad, controller, address),
    ]
    return cdb.Database(messages=messages,
                        nodes=[cdb.can.Node(keypad), cdb.can.Node(controller)],
                        dbc_specifics=_dbc_specifics())


def dbc_text(address: int = DEFAULT_ADDRESS, host: int = DEFAULT_HOST_ADDRESS) -> str:
    return str(database(address, host).as_dbc_string())


def write_dbc(path: str | os.PathLike[str], address: int = DEFAULT_ADDRESS,
              host: int = DEFAULT_HOST_ADDRESS) -> None:
    write_atomically(path, dbc_text(address, host).encode("utf-8"))
