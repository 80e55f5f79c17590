"""What the keypad shows: LED words rendered per key, the startup LED show and DEMO mode.

An LED word is the picture of PKP §11: ``width`` bits per colour, red first, then green, then
blue (bit k-1 of each colour is key k); the PKP-2600-SI's width is 12 (36 bits).

Blinking follows one model (PKP §12, §17 "if the blink message is sent when the LED is already
ON, the LED blinks in alternative mode"): each blink period has two phases; a channel that is
on and not blinking is lit in both, on and blinking in phase A only, blinking only in phase B
only. So red on + red/green blink alternates red and green (errata P9).

Durations the manuals do not give (blink period, show steps) are blinkcan decisions, named here.
"""

from __future__ import annotations

import itertools
from collections.abc import Mapping
from dataclasses import dataclass
from functools import cache
from types import MappingProxyType

from blinkcan.devices.colours import (
    BACKLIGHT_CHANNELS,
    BacklightColour,
    Channel,
    blink_phases,
    channel_name,
)
from blinkcan.devices.colours import key_channels as colour_key_channels
from blinkcan.devices.keypad import FACE, LEVEL_MAX, SHOW_COMPLETE, SHOW_FAST_FLASH
from blinkcan.twin.schedule import TICK_S, at, ticks

BLINK_PERIOD_S = 0.5  # one phase A + one phase B; not in the manual
#: the PKP-2600-SI's shows and DEMO mode below light its keys, one LED bit per key
_KEYS = FACE.keys
ALL_KEYS = (1 << _KEYS) - 1


def led_word(red: int, green: int, blue: int, width: int = _KEYS) -> int:
    mask = (1 << width) - 1
    return (red & mask) | (green & mask) << width | (blue & mask) << (2 * width)


def fill(keys_mask: int, channels: int, width: int = _KEYS) -> int:
    """An LED word lighting ``keys_mask`` in ``channels``."""
    return led_word(
        keys_mask if channels & Channel.RED else 0,
        keys_mask if channels & Channel.GREEN else 0,
        keys_mask if channels & Channel.BLUE else 0,
        width,
    )


def key_channels(word: int, key: int, width: int = _KEYS) -> int:
    """The channels of ``key`` lit in an LED word of ``width`` bits per colour."""
    return colour_key_channels(word, key, width)


def render_key(on: int, blink: int, key: int, width: int = _KEYS) -> dict[str, object]:
    """One key's LEDs for snapshot(): steady colour, blink colour, the two blink phases."""
    lit, blinking = key_channels(on, key, width), key_channels(blink, key, width)
    _, phase_b = blink_phases(lit, blinking)
    return {
        "colour": channel_name(lit),
        "blink_colour": channel_name(blinking),
        "alternate": bool(lit & blinking),
        "phases": [channel_name(lit), channel_name(phase_b)],
    }


@dataclass(frozen=True)
class ShowStep:
    """One step of a show: ``ticks`` long (whole ticks of ``schedule.TICK_S``), its picture."""

    ticks: int
    on: int
    blink: int = 0


_STEP = ticks(0.06)  # the complete show's fill steps (ours)
_WHITE = ticks(0.3)  # its last step, all keys white (ours)
_FLASH = ticks(0.1)  # fast flash: on and off (ours)


def _complete_show(keys: tuple[int, ...], width: int) -> tuple[ShowStep, ...]:
    """Each colour fills the keys one by one, then all keys white (durations ours)."""
    masks = [sum(1 << (key - 1) for key in keys[:count]) for count in range(1, len(keys) + 1)]
    steps = [ShowStep(_STEP, fill(mask, channel, width))
             for channel in (Channel.RED, Channel.GREEN, Channel.BLUE) for mask in masks]
    steps.append(ShowStep(_WHITE,
                          fill(masks[-1], Channel.RED | Channel.GREEN | Channel.BLUE, width)))
    return tuple(steps)


def _fast_flash(keys: tuple[int, ...], width: int) -> tuple[ShowStep, ...]:
    every = sum(1 << (key - 1) for key in keys)
    white = fill(every, Channel.RED | Channel.GREEN | Channel.BLUE, width)
    return (ShowStep(_FLASH, white), ShowStep(_FLASH, 0)) * 3


@cache
def startup_shows(keys: tuple[int, ...], width: int) -> Mapping[int, tuple[ShowStep, ...]]:
    """2014h's shows (PKP §23) on the keys that have an LED, in an LED word of ``width``;
    computed once per face (every twin of a model plays the same shows)."""
    return MappingProxyType({SHOW_COMPLETE: _complete_show(keys, width),
                             SHOW_FAST_FLASH: _fast_flash(keys, width)})


@cache
def _step_ends(steps: tuple[ShowStep, ...]) -> tuple[int, ...]:
    """When each step ends, in ticks from the start of a round (once per show)."""
    return tuple(itertools.accumulate(step.ticks for step in steps))


STARTUP_SHOWS = startup_shows(FACE.led_keys, _KEYS)
SHOW_NAMES = {0: "off", SHOW_COMPLETE: "complete", SHOW_FAST_FLASH: "fast flash"}


class ShowPlayer:
    """Plays a sequence of steps from ``start``, once or looping. Step ``i`` of round ``r``
    ends at ``schedule.at(start, r x length + its end in ticks)``: the one time
    :meth:`next_change` names and :meth:`step` turns at, so a change is always consumed."""

    def __init__(self, steps: tuple[ShowStep, ...], start: float, loop: bool = False) -> None:
        if not steps or any(step.ticks <= 0 for step in steps):
            raise ValueError("a show needs steps of at least one tick each")
        self.steps = steps
        self.start = start
        self.loop = loop
        self._ends = _step_ends(steps)
        self._length = self._ends[-1]

    def _locate(self, now: float) -> tuple[int, float] | None:
        """(step index, time that step ends) at ``now``, or None once a single play is over."""
        rounds = 0
        if self.loop and now > self.start:  # an estimate one round early, then exact
            rounds = max(0, int((now - self.start) / (self._length * TICK_S)) - 1)
        while True:
            played = rounds * self._length
            for index, end in enumerate(self._ends):
                ends_at = at(self.start, played + end)
                if ends_at > now:
                    return index, ends_at
            if not self.loop:
                return None
            rounds += 1

    def finished(self, now: float) -> bool:
        return self._locate(now) is None

    def step(self, now: float) -> ShowStep | None:
        located = self._locate(now)
        return None if located is None else self.steps[located[0]]

    def step_index(self, now: float) -> int | None:
        located = self._locate(now)
        return None if located is None else located[0]

    def next_change(self, now: float) -> float | None:
        """When the step shown at ``now`` ends: always after ``now`` (None: the show is over)."""
        located = self._locate(now)
        return None if located is None else located[1]


# -- DEMO mode (PKP §24 and appendix, errata P21) -------------------------------------------

#: Key 1 cycles the backlight: red, green, blue, yellow, cyan, magenta, white, amber,
#: yellow/green, off (None).
DEMO_COLOURS: tuple[BacklightColour | None, ...] = (*BacklightColour, None)
#: Key 4 step 3: keys n and n+6 blink alternately in these colours (errata P21).
DEMO_PAIR_COLOURS: tuple[Channel, ...] = (
    Channel.RED,
    Channel.RED | Channel.GREEN,  # amber
    Channel.RED | Channel.GREEN,  # yellow
    Channel.GREEN,
    Channel.GREEN | Channel.BLUE,  # cyan
    Channel.RED | Channel.GREEN | Channel.BLUE,  # white
)
DEMO_STEP_NAMES = ("complete LED show", "keys on in sequence", "alternate blinking pairs")
DEMO_LEVEL_STEP = 8  # keys 2 and 3 change the brightness by this much (ours)
_SEQUENCE_STEP = ticks(0.2)  # ours


def _pair_blink() -> tuple[int, int]:
    on = blink = 0
    for pair, channels in enumerate(DEMO_PAIR_COLOURS):
        first, second = 1 << pair, 1 << (pair + 6)
        on |= fill(first, channels)  # on + blink: lit in phase A
        blink |= fill(first | second, channels)  # blink only: lit in phase B
    return on, blink


class DemoMode:
    """DEMO mode's local state: the keys drive the LEDs and backlight, no host involved."""

    def __init__(self, now: float) -> None:
        self.colour_index = 0  # "Entering this mode, you turn on backlight red"
        self.step: int | None = None
        self.level = LEVEL_MAX
        self._player: ShowPlayer | None = None

    @property
    def backlight_colour(self) -> BacklightColour | None:
        return DEMO_COLOURS[self.colour_index]

    def press(self, key: int, now: float) -> None:
        if key == 1:
            self.colour_index = (self.colour_index + 1) % len(DEMO_COLOURS)
        elif key == 2:
            self.level = min(LEVEL_MAX, self.level + DEMO_LEVEL_STEP)
        elif key == 3:
            self.level = max(0, self.level - DEMO_LEVEL_STEP)
        elif key == 4:
            self.step = 0 if self.step is None else (self.step + 1) % len(DEMO_STEP_NAMES)
            self._player = self._make_player(now)
        # PKP appendix (rev 1.5): other keys have no effect in DEMO mode

    def release(self, key: int, now: float) -> None:
        """A key let go (PKP §24: nothing happens on release; a model may hold a repeat)."""

    def advance(self, now: float) -> None:
        """What DEMO mode does by itself by ``now`` beyond its show (PKP §24: nothing)."""

    def _make_player(self, now: float) -> ShowPlayer | None:
        if self.step == 0:
            return ShowPlayer(STARTUP_SHOWS[SHOW_COMPLETE], now, loop=True)
        if self.step == 1:
            steps = tuple(
                ShowStep(_SEQUENCE_STEP, (1 << count) - 1) for count in range(1, _KEYS + 1)
            )
            return ShowPlayer(steps, now, loop=True)
        return None

    def leds(self, now: float) -> tuple[int, int]:
        """(on word, blink word) shown at ``now``."""
        if self.step is None:
            return 0, 0
        if self.step == 2:
            return _pair_blink()
        assert self._player is not None
        step = self._player.step(now)
        assert step is not None
        if self.step == 1:  # keys in sequence, in the backlight colour (key 1 changes it)
            colour = self.backlight_colour
            return fill(step.on, BACKLIGHT_CHANNELS[colour] if colour else Channel.NONE), 0
        return step.on, step.blink

    def next_change(self, now: float) -> float | None:
        return None if self._player is None else self._player.next_change(now)

    def describe(self) -> dict[str, object]:
        colour = self.backlight_colour
        return {
            "backlight_colour": colour.label if colour else "off",
            "step": None if self.step is None else DEMO_STEP_NAMES[self.step],
            "level": self.level,
        }


def displayed_words(show: ShowPlayer | None, demo: DemoMode | None, on: int, blink: int,
                    now: float) -> tuple[int, int]:
    """(on word, blink word) the keys show at ``now``: a startup show still playing (PKP §23),
    else DEMO mode (§24), else the LED objects ``on`` and ``blink``. CANopen and J1939 modes
    alike."""
    if show is not None:
        step = show.step(now)
        if step is not None:
            return step.on, step.blink
    if demo is not None:
        return demo.leds(now)
    return on, blink
