"""The DBC of a PKP-2600-SI in J1939 mode, built with cantools from ``devices/keypad_j1939.py``.

A J1939 DBC as Vector tools and cantools read it: ``ProtocolType "J1939"``, each message's
``VFrameFormat`` ``J1939PG`` (cantools writes it for ``protocol="j1939"``), 29-bit identifiers
with the keypad's source address and the controller's. PGN EF00h carries a command byte (byte 2)
that selects the layout, so both directions are multiplexed messages: one signal set per
command, named ``<command>_<field>``. The LED acknowledge (§19) shares the keypad's identifier
but has no command byte, so no DBC multiplexer can tell it apart: it is left out (the decoder
names it).
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
    HEARTBEAT,
    KEY_MESSAGE,
    NIBBLE_BLINK,
    PGN_COMMAND,
    PGN_LEDS_COLOUR_1,
    PGN_LEDS_COLOUR_2,
    PRIORITY,
    SOFTWARE_REVISION_REPLY,
    LedState,
)
from blinkcan.formats.atomic import write_atomically
from blinkcan.protocol.j1939 import GLOBAL_ADDRESS, NAME_FIELDS, PGN_ADDRESS_CLAIMED, compose_id

_COMMAND_BYTE = 16  # bit position of byte 2
_STATES = {int(state): state.name.lower() for state in LedState}  # §7a


def _value(name: str, start: int, length: int, receivers: list[str], comment: str,
           choices: dict[int, str] | None = None, multiplexer_id: int | None = None) -> Signal:
    return Signal(name, start, length, byte_order="little_endian", is_signed=False,
                  comment=comment, receivers=receivers,
                  multiplexer_ids=None if multiplexer_id is None else [multiplexer_id],
                  multiplexer_signal=None if multiplexer_id is None else "command",
                  conversion=cdb.conversion.NamedSignalConversion(
                      1, 0, OrderedDict(choices), is_float=False) if choices else None)


def _header(receivers: list[str]) -> Signal:
    """Bytes 0-1, ``04 1B`` (§4): 1B04h read little-endian."""
    return Signal("header", 0, 16, byte_order="little_endian", is_signed=False,
                  receivers=receivers, comment="04 1B (§4): 0x1B04", raw_initial=0x1B04)


def _selector(codes: dict[int, str], receivers: list[str]) -> Signal:
    return Signal("command", _COMMAND_BYTE, 8, byte_order="little_endian", is_signed=False,
                  is_multiplexer=True, receivers=receivers, comment="Command byte (§4)",
                  conversion=cdb.conversion.NamedSignalConversion(
                      1, 0, OrderedDict(codes), is_float=False))


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
                   is_extended_frame=True, comment="Commands to the keypad (§4)")


def _messages(keypad: str, controller: str, address: int) -> Message:
    """From the keypad on PGN EF00h to all: key state, software revision, heartbeat."""
    receivers = [controller]
    signals = [
        _header(receivers),
        _selector({KEY_MESSAGE: "key", SOFTWARE_REVISION_REPLY: "software_revision",
                   HEARTBEAT: "heartbeat"}, receivers),
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
                   is_extended_frame=True, comment="Messages from the keypad (§6, §11, §18)")


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
