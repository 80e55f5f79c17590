"""The keypad's J1939 traffic as what happened ("keypad 21h: key 5 pressed"). Pure.

Everything is read from ``devices/keypad_j1939.py`` (command codes, fields, message layouts).
Which addresses are keypads: those the user names (``--device j1939:0x30=keypad``), else 21h
(the default, §5), and those learned from the bus: a keypad's own messages (heartbeat F9h,
software revision reply, key message), a source address command (70h), and an address claim
with the keypad's NAME. The same command byte 01h means "key state" from the keypad and "set
LED" to it, so the direction is told by the addresses: a frame to a keypad (or to all from a
non-keypad) is a command, a frame from a keypad is a message. Where the bytes decide (a key
message is no valid LED command: its secondary colour byte is FFh), they do, whatever the
addresses; a frame the addresses and bytes leave open is not given a meaning (raw).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any, NamedTuple

from blinkcan.devices.keypad_j1939 import (
    COLOUR_CODES,
    COMMANDS_BY_CODE,
    DEFAULT_ADDRESS,
    DEFAULT_NAME,
    HEADER,
    HEARTBEAT,
    KEY_MESSAGE,
    KEY_PRESSED,
    KEY_RELEASED,
    KEYS,
    NIBBLE_BLINK,
    PGN_COMMAND,
    PGN_LEDS_COLOUR_1,
    PGN_LEDS_COLOUR_2,
    SOFTWARE_REVISION_REPLY,
    TIME_UNIT_S,
    UNUSED,
    J1939Command,
    LedState,
    Persistence,
    command,
    split_nibbles,
)
from blinkcan.devices.keypad_j1939 import (
    LEVEL_MAX as J1939_LEVEL_MAX,
)
from blinkcan.devices.model import DeviceDescription
from blinkcan.protocol.frame import Frame
from blinkcan.protocol.items import item_numbers
from blinkcan.protocol.j1939 import (
    GLOBAL_ADDRESS,
    NULL_ADDRESS,
    PDU2_FORMAT_MIN,
    PGN_ADDRESS_CLAIMED,
    PGN_REQUEST,
    J1939Name,
    parse_id,
)

_SHOWS = {0: "off", 1: "complete", 2: "fast flash"}
_MODES = {0: "single-LED commands only", 2: "single and multiple LED commands"}
_BITRATES = {2: "500 kbit/s", 3: "250 kbit/s"}


_NO_FIELDS: dict[str, Any] = {}  # shared, never written

#: how a J1939 address is named where a CANopen node id would be: ``--device j1939:0x30=keypad``,
#: ``Decoder({"j1939:0x30": "keypad"})`` (as ``emulate keypad:0x30 --protocol j1939``)
J1939_NODE_PREFIX = "j1939:"
#: §16: the source addresses a keypad can take
_SOURCE_ADDRESSES = command("source_address").fields[0].valid


def j1939_node(address: int) -> str:
    """0x30 -> "j1939:0x30", the name of a J1939 address among node ids."""
    return f"{J1939_NODE_PREFIX}0x{address:02X}"


def is_j1939_node(node: object) -> bool:
    return isinstance(node, str) and node.lower().startswith(J1939_NODE_PREFIX)


def parse_j1939_node(node: str) -> int:
    """"j1939:0x30" (or "j1939:48", "j1939:30h") -> 0x30; ValueError naming the form and the
    range of a keypad's source address (§16)."""
    text = node[len(J1939_NODE_PREFIX):].strip().lower() if is_j1939_node(node) else None
    try:
        address = int(text[:-1], 16) if text and text.endswith("h") else int(text or "", 0)
    except ValueError:
        raise ValueError(f"{node!r}: name a J1939 address as j1939:ADDR, e.g. j1939:0x30") \
            from None
    if address not in _SOURCE_ADDRESSES:
        raise ValueError(f"{node!r}: a keypad's J1939 source address is "
                         f"{_SOURCE_ADDRESSES} (§16), not {address:#x}")
    return address


def is_key_message(data: bytes) -> bool:
    """Whether the bytes are exactly a §6 key message (``04 1B 01 <key> <00/01> <identifier>
    FF FF``). No command has them: the single-LED command's byte 6 is a colour (J-2)."""
    return len(data) == 8 and data[:3] == _KEY_MESSAGE_HEAD and 1 <= data[3] <= KEYS and \
        data[4] in _KEY_STATES and data[6] == UNUSED and data[7] == UNUSED


_KEY_MESSAGE_HEAD = HEADER + bytes((KEY_MESSAGE,))
_KEY_STATES = frozenset({KEY_PRESSED, KEY_RELEASED})


class J1939Meaning(NamedTuple):
    """What one extended frame meant. ``address`` is the keypad's (or the claimer's) address.
    A tuple (immutable, equal by value): one is made per keypad frame of a log."""

    text: str
    address: int | None
    keypad: bool
    fields: dict[str, Any] = _NO_FIELDS


def colour_name(code: int) -> str:
    return COLOUR_CODES.get(code, f"colour {code:02X}h")


def led_text(key: int, colour: int, state: int, secondary: int) -> str:
    """§7a as words: "LED 11 alternates red/green"."""
    if state == LedState.OFF or (colour == 0 and state != LedState.ALTERNATE):
        return f"LED {key} off"
    if state == LedState.ON:
        return f"LED {key} {colour_name(colour)}"
    if state == LedState.BLINK:
        return f"LED {key} blinks {colour_name(colour)}"
    return f"LED {key} alternates {colour_name(colour)}/{colour_name(secondary)}"


def _value_text(command: J1939Command, name: str, value: int) -> str:
    if name == "on":
        return "on" if value else "off"
    if name == "level":
        return f"{value}/{J1939_LEVEL_MAX}"
    if name == "period":
        return "unchanged" if value == 0xFF else f"{round(value * TIME_UNIT_S * 1000)} ms"
    if name == "colour":
        return colour_name(value)
    if name == "show":
        return _SHOWS[value]
    if name == "mode":
        return _MODES[value]
    if name == "code":
        return _BITRATES[value]
    if name in ("address", "identifier"):
        return "unchanged" if value == 0xFF else f"{value:02X}h"
    return f"{value:02X}h"


#: every PGN the keypad's traffic uses (§3, §7b, J1939-21 request, J1939-81 claim): a frame of
#: any other PGN is never the keypad's, whatever its addresses and data
KEYPAD_PGNS = frozenset({PGN_ADDRESS_CLAIMED, PGN_REQUEST, PGN_LEDS_COLOUR_1, PGN_LEDS_COLOUR_2,
                         PGN_COMMAND})


#: command meanings kept (then they start over): a few hundred kilobytes at most
_COMMANDS_KEPT = 1024


def _to_all(destination: int, meaning: J1939Meaning) -> J1939Meaning:
    """A command to the global address is no keypad's at FFh: every keypad takes it (spec
    J-2, J1939-21), so it names no address and says so."""
    if destination != GLOBAL_ADDRESS:
        return meaning
    return meaning._replace(text=f"{meaning.text}, to all keypads", address=None)


class J1939KeypadDecoder:
    """Decodes PKP-2600-SI J1939 frames; remembers which addresses are keypads. ``models``
    names the model at an address (the user said it: ``--device j1939:0x30=keypad``); those
    addresses are keypads too."""

    def __init__(self, addresses: Iterable[int] = (DEFAULT_ADDRESS,),
                 models: Mapping[int, DeviceDescription] | None = None) -> None:
        #: the model at each address the user named (an address learned has none)
        self.models: dict[int, DeviceDescription] = dict(models or {})
        self.addresses = set(addresses) | set(self.models)
        #: commands' meanings by (destination, bytes): their fields hold numbers only
        self._commands: dict[tuple[int, bytes], J1939Meaning] = {}

    @staticmethod
    def concerns(can_id: int) -> bool:
        """Whether a 29-bit identifier can carry the keypad's traffic (its PGN is one the
        keypad uses); False: :meth:`decode` says None for every frame with it."""
        return parse_id(can_id).pgn in KEYPAD_PGNS

    def decode(self, frame: Frame) -> J1939Meaning | None:
        """The meaning of an extended frame, or None for one that is not the keypad's."""
        can_id, data, extended = frame
        if not extended:
            return None
        # the identifier's fields (protocol/j1939.py parse_id, inline: one frame of many)
        pgn, source = (can_id >> 8) & 0x3FFFF, can_id & 0xFF
        if (pgn >> 8) & 0xFF < PDU2_FORMAT_MIN:  # PDU1: PS is the destination (J1939-21)
            destination, pgn = pgn & 0xFF, pgn & ~0xFF
        else:
            destination = GLOBAL_ADDRESS
        if pgn == PGN_COMMAND:
            return self._proprietary(source, destination, data)
        if pgn == PGN_ADDRESS_CLAIMED and len(data) == 8:
            return self._claim(source, J1939Name.from_bytes(data))
        if pgn == PGN_REQUEST and len(data) >= 3:
            requested = int.from_bytes(data[:3], "little")
            if requested == PGN_ADDRESS_CLAIMED:
                target = "all" if destination == GLOBAL_ADDRESS else f"{destination:02X}h"
                return J1939Meaning(f"request for address claimed, to {target}",
                                    source, False, {"source": source})
            return None
        if pgn in (PGN_LEDS_COLOUR_1, PGN_LEDS_COLOUR_2):
            if destination not in self.addresses and destination != GLOBAL_ADDRESS:
                return None
            return self._multiple_leds(pgn, destination, data)
        return None

    def _proprietary(self, source: int, destination: int, data: bytes) -> J1939Meaning | None:
        """PGN EF00h: a command to a keypad or a message from one, told by the addresses."""
        # only a keypad sends a heartbeat, a software revision or a key message (§18, §11,
        # §6): a keypad at its source address, whether it was known or not
        keypad_only = data[:2] == HEADER and len(data) == 8 and (
            data[2] == HEARTBEAT or (data[2] == SOFTWARE_REVISION_REPLY and data[3] != 0xFF)
            or is_key_message(data))
        addresses = self.addresses
        to_keypad = destination in addresses or (
            destination == GLOBAL_ADDRESS and source not in addresses)
        if to_keypad and data[:2] == HEADER and not keypad_only:
            meaning = self._command(destination, data)
            if meaning.fields["command"] is None and destination not in addresses:
                return None  # to all from an unknown sender, and no command: nobody can say
            return meaning
        if source in addresses or keypad_only:
            return self._message(source, data)
        return None

    # -- from the keypad ----------------------------------------------------------------------

    def _message(self, source: int, data: bytes) -> J1939Meaning | None:
        if len(data) == 8 and data[0] == 0x00:  # §19 LED acknowledge
            text = led_text(data[2], data[3], data[1], data[4])
            return J1939Meaning(f"acknowledged: {text}", source, True,
                                {"message": "led_acknowledge", "key": data[2]})
        if len(data) != 8 or data[:2] != HEADER:
            return None
        code = data[2]
        if code == KEY_MESSAGE:  # §6
            key, pressed, identifier = data[3], data[4] == 0x01, data[5]
            self.addresses.add(source)
            return J1939Meaning(f"key {key} {'pressed' if pressed else 'released'}", source,
                                True, {"message": "key", "key": key, "pressed": pressed,
                                       "identifier": identifier})
        if code == HEARTBEAT:  # §18
            self.addresses.add(source)
            keys = data[4] | (data[5] & 0x0F) << 8
            held = item_numbers(keys)
            listing = ", ".join(map(str, held)) if held else "none"
            return J1939Meaning(f"heartbeat {data[3]}, keys held: {listing}", source, True,
                                {"message": "heartbeat", "counter": data[3], "keys": held,
                                 "identifier": data[7]})
        if code == SOFTWARE_REVISION_REPLY and data[3] != 0xFF:  # §11
            self.addresses.add(source)
            revision = data[3:7].rstrip(b"\x00").decode("ascii", "replace")
            return J1939Meaning(f"software revision {revision}", source, True,
                                {"message": "software_revision", "revision": revision})
        return None

    # -- to the keypad ------------------------------------------------------------------------

    def _command(self, destination: int, data: bytes) -> J1939Meaning:
        """A command's meaning: the same bytes to the same address mean the same (commands
        repeat: LED states sent again and again), so meanings are kept, up to a bound."""
        key = (destination, data)
        meaning = self._commands.get(key)
        if meaning is None:
            meaning = _to_all(destination, self._describe_command(destination, data))
            if len(self._commands) >= _COMMANDS_KEPT:
                self._commands.clear()
            self._commands[key] = meaning
        fields = meaning.fields
        if fields["command"] == "source_address" and fields["address"] != 0xFF:
            self.addresses.add(fields["address"])  # §16: the keypad answers there from now
        return meaning

    def _describe_command(self, destination: int, data: bytes) -> J1939Meaning:
        command = COMMANDS_BY_CODE.get(data[2]) if len(data) > 2 else None
        fields = command.decode(data) if command is not None else None
        if command is None or fields is None:
            return J1939Meaning("malformed command (the keypad ignores it)", destination, True,
                                {"command": None})
        if command.name == "single_led":
            text = led_text(fields["key"], fields["colour"], fields["state"],
                            fields["secondary"])
        elif command.name == "software_revision":
            text = "software revision request"
        elif command.name == "switch_to_canopen":
            text = "switch to CANopen (§27, PKP §44)"
        else:
            values = ", ".join(_value_text(command, name, value)
                               for name, value in fields.items())
            text = f"{command.label.lower()} {values}" if len(fields) == 1 else \
                f"{command.label.lower()}: {values}"
            if command.persistence is Persistence.TEMPORARY:
                text += " until power-off"
        return J1939Meaning(text, destination, True, {"command": command.name, **fields})

    def _multiple_leds(self, pgn: int, destination: int, data: bytes) -> J1939Meaning:
        return _to_all(destination, self._leds_of(pgn, destination, data))

    @staticmethod
    def _leds_of(pgn: int, destination: int, data: bytes) -> J1939Meaning:
        which = 1 if pgn == PGN_LEDS_COLOUR_1 else 2
        if len(data) != 8:
            return J1939Meaning(f"LEDs colour {which}: malformed", destination, True)
        by_colour: dict[str, list[int]] = {}
        for key, nibble in enumerate(split_nibbles(data), start=1):
            if nibble:
                name = "blink" if nibble == NIBBLE_BLINK else colour_name(nibble)
                by_colour.setdefault(name, []).append(key)
        parts = "; ".join(f"{name} {', '.join(map(str, keys))}"
                          for name, keys in by_colour.items()) or "none"
        return J1939Meaning(f"LEDs colour {which}: {parts}", destination, True,
                            {"command": f"leds_colour_{which}",
                             "nibbles": split_nibbles(data)})

    # -- address claim ------------------------------------------------------------------------

    def _claim(self, source: int, name: J1939Name) -> J1939Meaning:
        keypad = name == DEFAULT_NAME
        if keypad and source != NULL_ADDRESS:
            self.addresses.add(source)
        text = "cannot claim an address" if source == NULL_ADDRESS else \
            f"address claim {source:02X}h"
        return J1939Meaning(f"{text}, NAME {name.to_bytes().hex(' ').upper()}", source, keypad,
                            {"name": name.to_bytes().hex()})
