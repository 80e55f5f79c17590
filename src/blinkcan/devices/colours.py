"""Colours: the key LEDs' RGB channels and the backlight's colour codes.

Each key has a red, a green and a blue LED (PKP §11); mixtures give the other colours. The
backlight takes a colour code (PKP §18c, 01h-09h).
"""

from __future__ import annotations

from enum import IntEnum, IntFlag


class Channel(IntFlag):
    """The three LEDs under a key; a colour is a set of channels."""

    NONE = 0
    RED = 1
    GREEN = 2
    BLUE = 4


#: Key LED colour names -> channels. Amber and yellow are the same mixture on these LEDs.
LED_COLOURS: dict[str, Channel] = {
    "off": Channel.NONE,
    "red": Channel.RED,
    "green": Channel.GREEN,
    "blue": Channel.BLUE,
    "yellow": Channel.RED | Channel.GREEN,
    "amber": Channel.RED | Channel.GREEN,
    "cyan": Channel.GREEN | Channel.BLUE,
    "magenta": Channel.RED | Channel.BLUE,
    "white": Channel.RED | Channel.GREEN | Channel.BLUE,
}

_CHANNEL_NAMES: dict[Channel, str] = {
    Channel.NONE: "off",
    Channel.RED: "red",
    Channel.GREEN: "green",
    Channel.BLUE: "blue",
    Channel.RED | Channel.GREEN: "yellow",
    Channel.GREEN | Channel.BLUE: "cyan",
    Channel.RED | Channel.BLUE: "magenta",
    Channel.RED | Channel.GREEN | Channel.BLUE: "white",
}


def key_channels(word: int, key: int, width: int) -> int:
    """The channels of ``key`` lit in an LED word of ``width`` bits per colour, red, green,
    blue from bit 0 (PKP §11; the word behind 2001h/2002h and the LED PDOs)."""
    bit = key - 1
    return (
        (word >> bit) & 1
        | ((word >> (width + bit)) & 1) << 1
        | ((word >> (2 * width + bit)) & 1) << 2
    )


def channel_name(channels: int) -> str:
    """The colour name of a set of channels ("yellow" for red + green)."""
    return _CHANNEL_NAMES[Channel(channels & 7)]


def blink_phases(lit: int, blinking: int) -> tuple[int, int]:
    """The channels a key shows in the two phases of a blink period (PKP §12, §17: "if the blink
    message is sent when the LED is already ON, the LED blinks in alternative mode"; errata P9):
    on and not blinking is lit in both, on and blinking in phase A only, blinking only in phase
    B only. Red on + red/green blinking alternates red and green."""
    return lit, (lit & ~blinking) | (blinking & ~lit)


def led_colour(name: str) -> Channel:
    """Channels of a colour name; raises ValueError naming the valid names."""
    try:
        return LED_COLOURS[name.lower()]
    except (KeyError, AttributeError):
        raise ValueError(
            f"unknown LED colour {name!r}; valid: {', '.join(LED_COLOURS)}"
        ) from None


class BacklightColour(IntEnum):
    """Backlight colour codes (PKP §18c/d). 06h is printed "violet" and "magenta" (errata P22)."""

    RED = 0x01
    GREEN = 0x02
    BLUE = 0x03
    YELLOW = 0x04
    CYAN = 0x05
    MAGENTA = 0x06
    WHITE = 0x07
    AMBER = 0x08
    YELLOW_GREEN = 0x09

    @property
    def label(self) -> str:
        """The colour's one name, as the LEDs' colour codes (§7a) name it: "yellow/green"."""
        return self.name.lower().replace("_", "/")

    @classmethod
    def is_code(cls, code: int) -> bool:
        """Whether ``code`` is a backlight colour (01h-09h, PKP §18c/d)."""
        return code in cls._value2member_map_

    @classmethod
    def from_name(cls, name: str) -> BacklightColour:
        key = name.lower().replace("/", "_").replace("-", "_").replace(" ", "_")
        key = _BACKLIGHT_ALIASES.get(key, key)
        try:
            return cls[key.upper()]
        except KeyError:
            valid = ", ".join(c.label for c in cls)
            raise ValueError(f"unknown backlight colour {name!r}; valid: {valid}") from None


_BACKLIGHT_ALIASES = {
    "violet": "magenta",
    "white_light_blue": "white",
    "light_blue": "white",
    "orange": "amber",
    "amber_orange": "amber",
}

#: What each backlight colour looks like on a key's RGB LEDs (DEMO mode lights keys in it).
BACKLIGHT_CHANNELS: dict[BacklightColour, Channel] = {
    BacklightColour.RED: Channel.RED,
    BacklightColour.GREEN: Channel.GREEN,
    BacklightColour.BLUE: Channel.BLUE,
    BacklightColour.YELLOW: Channel.RED | Channel.GREEN,
    BacklightColour.CYAN: Channel.GREEN | Channel.BLUE,
    BacklightColour.MAGENTA: Channel.RED | Channel.BLUE,
    BacklightColour.WHITE: Channel.RED | Channel.GREEN | Channel.BLUE,
    BacklightColour.AMBER: Channel.RED | Channel.GREEN,
    BacklightColour.YELLOW_GREEN: Channel.RED | Channel.GREEN,
}
