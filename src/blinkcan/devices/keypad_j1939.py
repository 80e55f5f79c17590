"""PKP-2600-SI in J1939 mode: identifiers, commands, messages and settings as data.

Restates spec/pkp-2600-si-j1939.md (Blink's "PKP2600SI J1939" manual rev 1.5; § numbers are its
own). Every command is one :class:`J1939Command`: its code (byte 2 of ``04 1B <cmd> ...``), its
fields with their ranges and defaults, and whether they are stored. The twin, the driver, the
decoder and the DBC writer all read these tables; none restates a code or a range.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import Enum

from blinkcan.devices.colours import BACKLIGHT_CHANNELS, BacklightColour, Channel
from blinkcan.devices.objects import Ranges, values
from blinkcan.protocol.j1939 import GLOBAL_ADDRESS, J1939Name

#: §4: every message on PGN EF00h starts with these two bytes; unused bytes are FFh.
HEADER = bytes((0x04, 0x1B))
UNUSED = 0xFF
_PADDING = bytes((UNUSED,)) * 8
PGN_COMMAND = 0xEF00  # §3: proprietary A, PDU1 (PS = destination address)
PGN_LEDS_COLOUR_1 = 0xA700  # §7b
PGN_LEDS_COLOUR_2 = 0xA600  # §7b
PRIORITY = 6  # §3
DEFAULT_ADDRESS = 0x21  # §5: source address and keypad identifier
DEFAULT_HOST_ADDRESS = 0x00  # the sender SA of the manual's examples (18EF2100h)
#: J-5: the NAME the sibling manuals print (arbitrary-address capable)
DEFAULT_NAME = J1939Name.from_bytes(bytes.fromhex("3F426F1A00823CC0"))
SOFTWARE_REVISION = "V2.6"  # §11 prints V2.XX; sibling manuals print 56 32 2E 36 = "V2.6"
LEVEL_MAX = 0x3F  # §8/§9/§24/§25
TIME_UNIT_S = 0.010  # §17/§18: periods in 10 ms
BITRATES = {0x02: 500_000, 0x03: 250_000}  # §15; other codes: no change

#: §7a LED colour codes (also the backlight's, §26, and the nibbles of §7b)
COLOUR_OFF = 0x00
COLOUR_CODES: dict[int, str] = {0x00: "off",
                                 **{int(c): c.label for c in BacklightColour}}
NIBBLE_BLINK = 0xF  # §7b: a colour and Fh blinks in that colour


class LedState(int, Enum):
    """§7a byte 5 of the single-LED command."""

    OFF = 0x00
    ON = 0x01
    BLINK = 0x02
    ALTERNATE = 0x03  # primary / secondary colour


class Persistence(str, Enum):
    NONE = "none"  # a request or an action (LED, software revision, switch)
    TEMPORARY = "temporary"  # live until the next power-on, which loads a stored start value
    STORED = "stored"  # non-volatile, applied at once (baud rate: at the next power-on, J-3)


@dataclass(frozen=True)
class J1939Field:
    """One data byte of a command (d3 = byte 3, ...). ``setting`` names the value it sets;
    ``keep`` is the code meaning "leave unchanged" (§16: FFh)."""

    name: str
    label: str
    valid: Ranges
    default: int | None = None
    setting: str | None = None
    keep: int | None = None
    #: every byte value accepted, ``keep`` included (computed: a set look-up per byte)
    accepted: frozenset[int] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        accepted = {value for value in range(256) if value in self.valid}
        if self.keep is not None:
            accepted.add(self.keep)
        object.__setattr__(self, "accepted", frozenset(accepted))

    def accepts(self, value: int) -> bool:
        return value in self.accepted


@dataclass(frozen=True)
class J1939Command:
    code: int
    name: str
    label: str
    section: str
    fields: tuple[J1939Field, ...] = ()
    persistence: Persistence = Persistence.STORED

    def encode(self, *values_: int) -> bytes:
        """``04 1B <code> <fields...>`` padded with FFh to 8 bytes; ValueError if out of range."""
        if len(values_) != len(self.fields):
            raise ValueError(f"J1939 command {self.name} takes {len(self.fields)} value(s)")
        for each, value in zip(self.fields, values_, strict=True):
            if not each.accepts(value):
                raise ValueError(f"{self.name} {each.name} must be {each.valid}, not "
                                 f"{value:#x}")
        data = HEADER + bytes((self.code, *values_))
        return data + bytes((UNUSED,)) * (8 - len(data))

    def decode(self, data: bytes) -> dict[str, int] | None:
        """The fields of a command frame, or None if it is malformed (J-2: no change).

        The unused bytes must be FFh (§4). That rule is also what keeps one keypad's messages,
        sent to all (FFh), from being taken for commands by another: a software revision reply
        (``2A`` + ASCII) is no request, a key message (``01``, FFh where the LED command has its
        secondary colour) no LED command (blinkcan decision, J-2)."""
        used = 3 + len(self.fields)
        if len(data) != 8 or data[:2] != HEADER or data[2] != self.code or \
                data[used:] != _PADDING[used:]:
            return None
        decoded = {}
        for offset, each in enumerate(self.fields, start=3):
            value = data[offset]
            if value not in each.accepted:
                return None
            decoded[each.name] = value
        return decoded


def _flag(setting: str, label: str, default: int) -> J1939Field:
    return J1939Field("on", label, values(0, 1), default, setting)


def _level(setting: str | None, label: str, default: int) -> J1939Field:
    return J1939Field("level", label, values((0, LEVEL_MAX)), default, setting)


_KEY = values((1, 12))
_COLOUR = values((0x00, 0x09))
_PERIOD = values((0x05, 0xFE))  # x 10 ms

COMMANDS: tuple[J1939Command, ...] = (
    J1939Command(0x01, "single_led", "Single LED", "§7a", (
        J1939Field("key", "Key", _KEY),
        J1939Field("colour", "Colour", _COLOUR),
        J1939Field("state", "State", values((0, 3))),
        J1939Field("secondary", "Secondary colour", _COLOUR),
    ), Persistence.NONE),
    J1939Command(0x02, "led_brightness", "LED brightness", "§8",
                 (_level("led_brightness", "LED brightness", LEVEL_MAX),), Persistence.TEMPORARY),
    J1939Command(0x03, "backlight_level", "Backlight level", "§9",
                 (_level("backlight_level", "Backlight level", 0),), Persistence.TEMPORARY),
    J1939Command(0x28, "key_message_at_startup", "Key message at start-up", "§10",
                 (_flag("key_message_at_startup", "On", 0),)),
    J1939Command(0x2A, "software_revision", "Software revision request", "§11", (),
                 Persistence.NONE),
    J1939Command(0x34, "startup_led_show", "Startup LED show", "§12", (
        J1939Field("show", "Show (off, complete, fast flash)", values((0, 2)), 0x01,
                   "startup_led_show"),)),
    J1939Command(0x37, "led_management", "LED management mode", "§13", (
        J1939Field("mode", "Mode (00h single only, 02h single and multiple)", values(0, 2),
                   0x00, "led_management"),)),
    J1939Command(0x6E, "destination_address", "Destination address of key messages", "§14", (
        J1939Field("address", "Destination address", values((0x00, 0xFD), 0xFF),
                   GLOBAL_ADDRESS, "destination_address"),)),
    J1939Command(0x6F, "baud_rate", "Baud rate", "§15", (
        J1939Field("code", "Code (02h 500k, 03h 250k)", values(*BITRATES), 0x03, "baud_rate"),)),
    J1939Command(0x70, "source_address", "Source address and keypad identifier", "§16", (
        J1939Field("address", "Source address", values((0x01, 0xFD)), DEFAULT_ADDRESS,
                   "source_address", keep=0xFF),
        J1939Field("identifier", "Keypad identifier", values((0x00, 0xFD)), DEFAULT_ADDRESS,
                   "identifier", keep=0xFF),
    )),
    J1939Command(0x71, "periodic_key_state", "Periodic key state", "§17",
                 (_flag("periodic_key_state", "On", 0),)),
    J1939Command(0x72, "event_key_state", "Event key state", "§17",
                 (_flag("event_key_state", "On", 1),)),
    J1939Command(0x73, "led_acknowledge", "LED acknowledge", "§19",
                 (_flag("led_acknowledge", "On", 0),)),
    J1939Command(0x74, "address_claim", "Address claim at boot", "§20",
                 (_flag("address_claim", "On", 0),)),
    J1939Command(0x75, "heartbeat", "Heartbeat", "§18", (
        _flag("heartbeat", "On", 0),
        # blinkcan decision: FFh leaves the period unchanged (so "75 00 FF" just switches off)
        J1939Field("period", "Period (x 10 ms)", _PERIOD, 0x0A, "heartbeat_period", keep=0xFF),
    )),
    J1939Command(0x77, "key_message_period", "Key message period", "§17", (
        J1939Field("period", "Period (x 10 ms)", _PERIOD, 0x0A, "key_message_period"),)),
    J1939Command(0x7A, "demo_mode", "Demo mode at the next power-on", "§22",
                 (_flag("demo_mode", "On", 0),)),
    J1939Command(0x7B, "startup_backlight_level", "Backlight level at start-up", "§24",
                 (_level("startup_backlight_level", "Level", 0),)),
    J1939Command(0x7C, "startup_led_brightness", "LED brightness at start-up", "§25",
                 (_level("startup_led_brightness", "Level", LEVEL_MAX),)),
    J1939Command(0x7D, "backlight_colour", "Backlight colour", "§26", (
        J1939Field("colour", "Colour", values((0x01, 0x09)), int(BacklightColour.AMBER),
                   "backlight_colour"),)),
    J1939Command(0x80, "switch_to_canopen", "Switch to CANopen", "§27",
                 (J1939Field("zero", "00h", values(0)),), Persistence.NONE),
)

COMMANDS_BY_CODE: dict[int, J1939Command] = {c.code: c for c in COMMANDS}
COMMANDS_BY_NAME: dict[str, J1939Command] = {c.name: c for c in COMMANDS}

#: The stored settings (setting name -> its field); NVM keys carry the prefix below, so they
#: never meet a CANopen object of the same name ("baud_rate", "demo_mode").
NVM_PREFIX = "j1939_"
STORED_SETTINGS: dict[str, J1939Field] = {
    f.setting: f for c in COMMANDS if c.persistence is Persistence.STORED
    for f in c.fields if f.setting is not None
}
#: Live values loaded from a stored start value at power-on (§8/§9 "back to the 7Ch/7Bh value")
POWER_ON_FROM = {"led_brightness": "startup_led_brightness",
                 "backlight_level": "startup_backlight_level"}


def default_settings() -> dict[str, int]:
    return {name: f.default for name, f in STORED_SETTINGS.items() if f.default is not None}


def command(name: str) -> J1939Command:
    try:
        return COMMANDS_BY_NAME[name]
    except KeyError:
        raise ValueError(f"unknown J1939 command {name!r}; known: "
                         f"{', '.join(COMMANDS_BY_NAME)}") from None


# -- messages from the keypad (§6, §11, §18, §19) ----------------------------------------------

KEY_MESSAGE = 0x01  # §6 key contact state: 04 1B 01 <key> <state> <identifier> FF FF
KEYS = 12  # §6: the key messages name keys 1..12
SOFTWARE_REVISION_REPLY = 0x2A  # §11: 04 1B 2A <4 ASCII> 00
HEARTBEAT = 0xF9  # §18: 04 1B F9 <counter> <K8..K1> <0000 K12..K9> FF <identifier>
KEY_RELEASED, KEY_PRESSED = 0x00, 0x01


def key_message(key: int, pressed: bool, identifier: int) -> bytes:
    return HEADER + bytes((KEY_MESSAGE, key, KEY_PRESSED if pressed else KEY_RELEASED,
                           identifier, UNUSED, UNUSED))


def heartbeat_message(counter: int, keys: int, identifier: int) -> bytes:
    """``keys``: bit k-1 = key k held (§18: byte 4 K8..K1, byte 5 low nibble K12..K9)."""
    return HEADER + bytes((HEARTBEAT, counter & 0xFF, keys & 0xFF, (keys >> 8) & 0x0F, UNUSED,
                           identifier))


def software_revision_message(revision: str = SOFTWARE_REVISION) -> bytes:
    text = revision.encode("ascii")[:4].ljust(4, b"\x00")
    return HEADER + bytes((SOFTWARE_REVISION_REPLY,)) + text + b"\x00"


def led_acknowledge(state: int, key: int, colour: int, secondary: int) -> bytes:
    """§19: ``00 <state> <LED> <primary> <secondary> FF FF FF`` (no 04 1B header)."""
    return bytes((0x00, state, key, colour, secondary, UNUSED, UNUSED, UNUSED))


# -- multiple-LED frames (§7b) ---------------------------------------------------------------

MULTI_LED_COUNT = 12


def split_nibbles(data: bytes) -> list[int]:
    """Bytes 0-5 of a §7b frame: byte n = LED 2n+1 (low nibble), LED 2n+2 (high nibble)."""
    nibbles = []
    for byte in data[:MULTI_LED_COUNT // 2]:
        nibbles += [byte & 0x0F, byte >> 4]
    return nibbles


def join_nibbles(nibbles: list[int]) -> bytes:
    """The 8 data bytes of a §7b frame for LEDs 1-12 (bytes 6-7 FFh)."""
    if len(nibbles) != MULTI_LED_COUNT or not all(0 <= n <= 0xF for n in nibbles):
        raise ValueError("a multiple-LED frame holds 12 nibbles 0h..Fh")
    return bytes(nibbles[i] | nibbles[i + 1] << 4 for i in range(0, 12, 2)) + b"\xff\xff"


@dataclass(frozen=True)
class LedLook:
    """What one LED does: a state of §7a and its colour codes."""

    state: LedState
    colour: int = COLOUR_OFF
    secondary: int = COLOUR_OFF


def colour_name(code: int) -> str:
    """The §7a name of a colour code ("amber", "yellow/green"; unknown codes by number)."""
    return COLOUR_CODES.get(code, f"colour {code:02X}h")


def colour_code(name: str) -> int:
    """The §7a code of a colour name: off, the codes 01h-09h by name ("amber", "orange",
    "yellow/green", "white", "light blue", ...); ValueError naming the valid ones."""
    if name.lower() == "off":
        return COLOUR_OFF
    try:
        return int(BacklightColour.from_name(name))
    except (ValueError, AttributeError):
        raise ValueError(f"unknown J1939 LED colour {name!r}; valid: "
                         f"{', '.join(COLOUR_CODES.values())}") from None


def led_look(colour: str, blink: str | None = None) -> LedLook:
    """The §7a command for ``set_led(key, colour, blink)``: steady without ``blink``; the same
    colour (or ``colour="off"``) blinks; two colours alternate (primary, secondary)."""
    first = colour_code(colour)
    if blink is None:
        return LedLook(LedState.ON if first else LedState.OFF, first)
    second = colour_code(blink)
    if not first and not second:
        return LedLook(LedState.OFF)
    if first == second or not first or not second:
        return LedLook(LedState.BLINK, first or second)
    return LedLook(LedState.ALTERNATE, first, second)


def look_phases(look: LedLook) -> tuple[str, str]:
    """The colour names one LED shows in the two blink phases (§7a: blinking starts lit)."""
    primary = colour_name(look.colour) if look.state is not LedState.OFF else "off"
    if look.state is LedState.BLINK:
        return primary, "off"
    if look.state is LedState.ALTERNATE:
        return primary, colour_name(look.secondary)
    return primary, primary


def colour_channels(code: int) -> Channel:
    """A §7a colour code as the key's RGB channels (J-4: CANopen mode's colours)."""
    if 1 <= code <= 9:
        return BACKLIGHT_CHANNELS[BacklightColour(code)]
    return Channel.NONE


def channels_colour(channels: int) -> int:
    """The §7a code that lights ``channels`` (the lowest: red + green is 04h yellow, the
    mixture amber and yellow/green also make on these LEDs, J-4)."""
    if not channels & 7:
        return COLOUR_OFF
    return min(code for code, lit in BACKLIGHT_CHANNELS.items() if lit == Channel(channels & 7))


def look_channels(look: LedLook) -> tuple[Channel, Channel]:
    """(on, blink) channels of one LED in CANopen mode's picture (PKP §12 phases, J-4): on =
    the phase A colour, blink = the channels that change in phase B."""
    primary, secondary = colour_channels(look.colour), colour_channels(look.secondary)
    if look.state is LedState.ON:
        return primary, Channel.NONE
    if look.state is LedState.BLINK:
        return primary, primary
    if look.state is LedState.ALTERNATE:
        return primary, primary ^ secondary
    return Channel.NONE, Channel.NONE


def nibbles_to_look(colour_1: int, colour_2: int) -> LedLook:
    """§7b per LED: both 0 off; one colour and 0 on; the same colour twice, or a colour and Fh,
    blinks; two colours alternate. Codes outside 1h-9h (and Fh with nothing) are off (ours)."""
    valid = range(1, 10)
    if colour_1 in valid and colour_2 in valid:
        if colour_1 == colour_2:
            return LedLook(LedState.BLINK, colour_1)
        return LedLook(LedState.ALTERNATE, colour_1, colour_2)
    for colour, other in ((colour_1, colour_2), (colour_2, colour_1)):
        if colour in valid:
            if other == NIBBLE_BLINK:
                return LedLook(LedState.BLINK, colour)
            if other == COLOUR_OFF:
                return LedLook(LedState.ON, colour)
    return LedLook(LedState.OFF)
