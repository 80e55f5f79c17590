"""What a person does to a device with their hands, read from its face: press a key, turn a
knob, set an input, blow a fuse, switch the power.

One table for every front end that acts on a twin (the web panel, ``blinkcan emulate``'s typed
commands). An action has the arguments its face gives a range for (keys 1..keys, pins
1..pins, encoders, inputs, volts); a device has the action when every one of those ranges is
non-empty, so a new model's face brings its actions with it. ``perform(twin, arguments, now)``
calls the twin's physical-side method and returns the frames the device sends; front ends run
it on the emulator's loop (``Emulator.run``), never from their own thread.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any

from blinkcan.devices.model import Face

#: a knob turned from a front end moves at most this many ticks at once (16 = one turn)
TICKS_PER_ACTION = 64


@dataclass(frozen=True)
class Argument:
    """One argument of an action: its name and its valid range on a face (inclusive; a float
    low end makes it a number, an int one an integer; high < low: the face has none)."""

    name: str
    span: Callable[[Face], tuple[float, float]]

    def bounds(self, face: Face) -> tuple[float, float]:
        return self.span(face)

    def is_integer(self, face: Face) -> bool:
        return not isinstance(self.bounds(face)[0], float)

    def describe(self, face: Face) -> str:
        """"key 1..12", "volts 0.0..5.0": the name and its range on ``face``."""
        low, high = self.bounds(face)
        return f"{self.name} {low}..{high}"

    def check(self, face: Face, value: object) -> int | float:
        """``value`` if it is in range on ``face`` (ValueError naming the range otherwise)."""
        low, high = self.bounds(face)
        kinds = (int,) if self.is_integer(face) else (int, float)
        if isinstance(value, bool) or not isinstance(value, kinds) \
                or not low <= value <= high:  # NaN fails the comparison
            raise ValueError(f"{self.name} must be {low}..{high}, not {value!r}")
        return value


@dataclass(frozen=True)
class Action:
    """One thing a hand does to a device; ``doing`` says it in a few words."""

    name: str
    doing: str
    arguments: tuple[Argument, ...]
    perform: Callable[[Any, Mapping[str, Any], float], object]

    def fits(self, face: Face) -> bool:
        """True when ``face`` has what this action needs (a key to press, a fuse to blow)."""
        return all(low <= high for low, high in (a.bounds(face) for a in self.arguments))

    def check(self, face: Face, values: Mapping[str, object]) -> dict[str, int | float]:
        """The arguments in ``values``, each checked against ``face`` (ValueError naming what
        is valid)."""
        for argument in self.arguments:
            low, high = argument.bounds(face)
            if high < low:
                raise ValueError(f"this device has nothing for {self.name!r} (no "
                                 f"{argument.name} on its face)")
        return {argument.name: argument.check(face, values.get(argument.name))
                for argument in self.arguments}


def _count(what: Callable[[Face], int]) -> Callable[[Face], tuple[float, float]]:
    """Numbers 1..N of what a face has N of."""
    return lambda face: (1, what(face))


_KEY = Argument("key", _count(lambda face: face.keys))
_PIN = Argument("pin", _count(lambda face: face.pins))
_ENCODER = Argument("encoder", _count(lambda face: len(face.encoders)))
_TICKS = Argument("ticks", lambda face: (-TICKS_PER_ACTION, TICKS_PER_ACTION)
                  if face.encoders else (0, -1))
_ANALOG = Argument("input", lambda face: (0, face.analog_inputs - 1))
_VOLTS = Argument("volts", lambda face: (0.0, face.analog_volts_max)
                  if face.analog_inputs else (0.0, -1.0))
_DIGITAL = Argument("input", lambda face: (0, face.digital_inputs - 1))
_LEVEL = Argument("level", lambda face: (0, 1) if face.digital_inputs else (0, -1))

#: every action, by name (the web panel's API and the typed commands use these names)
ACTIONS: Mapping[str, Action] = MappingProxyType({action.name: action for action in (
    Action("press", "press a key", (_KEY,), lambda t, a, now: t.press(a["key"], now)),
    Action("release", "release a key", (_KEY,), lambda t, a, now: t.release(a["key"], now)),
    Action("turn", "turn a knob (ticks > 0: clockwise, 16 a turn)", (_ENCODER, _TICKS),
           lambda t, a, now: t.turn(a["encoder"], a["ticks"], now)),
    Action("set_analog", "put a voltage on an analog input", (_ANALOG, _VOLTS),
           lambda t, a, now: t.set_analog(a["input"], a["volts"], now)),
    Action("set_digital_input", "drive a digital input low (0) or high (1)",
           (_DIGITAL, _LEVEL),
           lambda t, a, now: t.set_digital_input(a["input"], bool(a["level"]), now)),
    Action("blow_fuse", "blow an output's fuse (the output goes to FAULT)", (_PIN,),
           lambda t, a, now: t.blow_fuse(a["pin"], now)),
    Action("replace_fuse", "replace an output's fuse (its FAULT stays until a RESET)", (_PIN,),
           lambda t, a, now: t.replace_fuse(a["pin"], now)),
    Action("input_high", "drive a pin's input high", (_PIN,),
           lambda t, a, now: t.set_input(a["pin"], True, now)),
    Action("input_low", "drive a pin's input low", (_PIN,),
           lambda t, a, now: t.set_input(a["pin"], False, now)),
    Action("power_off", "switch the power off (live state lost)", (),
           lambda t, a, now: t.power_off()),
    Action("power_on", "switch the power on (boot-up, stored settings back)", (),
           lambda t, a, now: t.power_on(now)),
)})


def actions_of(face: Face) -> tuple[Action, ...]:
    """The actions a device with ``face`` has, in the table's order."""
    return tuple(action for action in ACTIONS.values() if action.fits(face))


__all__ = ["ACTIONS", "TICKS_PER_ACTION", "Action", "Argument", "actions_of"]
