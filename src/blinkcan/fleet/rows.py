"""Decoder events as table rows: what each event says about keys, LEDs, outputs and faults.

One event can be several rows (a key-state frame that presses two keys is two ``key`` rows)
and is always at least one, so every frame of a log is in the table. Where a frame repeats
a device's state (the Keybox's periodic fault message, KBX §25; an LED frame sent again), the
row says ``unchanged`` rather than repeating the pins or keys: a ``fault`` row with a pin is a
pin that went into FAULT (``fault``) or out of it (``cleared``), so counting them counts fuse
blows. The state followed per node starts where the devices start (LEDs dark, outputs OFF, no
FAULT) and restarts at each boot-up. No pyarrow here: the rows are plain tuples.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, NamedTuple

from blinkcan.decode.decoder import Decoder, Event, Kind, numbers
from blinkcan.decode.j1939 import colour_name
from blinkcan.devices.colours import channel_name
from blinkcan.devices.keypad_j1939 import LedState
from blinkcan.devices.registry import describe_device

#: the event kinds of the table, in the order the schema documents them
KINDS = ("key", "led", "output", "fault", "heartbeat", "nmt", "sdo", "j1939", "pdo", "sync",
         "remote", "error", "undecoded", "unreadable")
_DARK = (0, 0, 0)
_LED_STATES = {"led_on": "on", "led_blink": "blink"}
_COLOUR_NAMES = tuple(channel_name(channels) for channels in range(8))
_NAMES = {kind: kind.value for kind in Kind}  # an Enum's value is a slow property


class Detail(NamedTuple):
    """The per-row part of an event's rows (the rest is the event's own time, frame, text)."""

    kind: str
    key: int | None = None
    pin: int | None = None
    state: str | None = None
    colour: str | None = None
    value: int | None = None


#: the rows of events that carry nothing but their kind (shared: rows are never changed)
SIMPLE_ROWS = {kind: [Detail(name)] for kind, name in (
    (Kind.SYNC, "sync"), (Kind.REMOTE, "remote"), (Kind.ERROR, "error"),
    (Kind.FRAME, "undecoded"))}


_LED_UNCHANGED = Detail("led", state="unchanged")
_OUTPUT_UNCHANGED = Detail("output", state="unchanged")
_new = tuple.__new__  # a Detail without the call to its __new__: many rows are made


def _mask(items: list[int]) -> int:
    """The mask of item numbers (1 is bit 0): decode.decoder.numbers the other way."""
    mask = 0
    for item in items:
        mask |= 1 << (item - 1)
    return mask


class Rowed(NamedTuple):
    """An event's rows: the node and model they are about, and one detail per row."""

    node: int | None
    model: str | None
    details: list[Detail]


def _int_value(value: object) -> int | None:
    return value if isinstance(value, int) and not isinstance(value, bool) else None


class EventRows:
    """Rows of the events of one log, in order (it follows each node's LEDs, outputs and
    faults to say what changed)."""

    def __init__(self, decoder: Decoder) -> None:
        self._devices = decoder.devices  # the decoder's own: it learns models from the bus
        self._j1939_models = decoder.j1939.models  # J1939 addresses the user named
        #: (node, pdo) -> the keys lit red, green, blue (masks: bit 0 is key 1)
        self._leds: dict[tuple[int, str], tuple[int, int, int]] = {}
        self._outputs: dict[int, int] = {}  # node -> the pins HIGH (a mask: bit 0 is pin 1)
        self._faults: dict[int, int] = {}  # node -> the pins in FAULT (a mask)
        #: node -> what is followed of it (its LEDs, outputs, faults), made again on a change
        self._states: dict[int, tuple[object, ...]] = {}
        #: changes of what is followed, counted (a frame that left it alone changed nothing)
        self.changes = 0
        #: reads of what is followed, counted (rows made without one depend on no state)
        self.reads = 0
        self._models: dict[str, str] = {}
        self._heartbeats: dict[object, list[Detail]] = {}  # state -> its row (shared)
        self._pdo: dict[str, Callable[[int, dict[str, Any]], list[Detail]]] = {
            "key_state": self._keys, "led_on": self._led_picture,
            "led_blink": self._led_picture, "outputs": self._output_states,
            "faults": self._fault_pins,
        }

    def state(self, node: int | None) -> tuple[object, ...] | None:
        """What is followed of a node (None: nothing yet): with the same event, the same
        state gives the same rows (an event's rows read only its node's)."""
        return self._states.get(node) if node is not None else None

    def _changed(self, node: int) -> None:
        self.changes += 1
        self._states[node] = (tuple(sorted((k[1], v) for k, v in self._leds.items()
                                           if k[0] == node)),
                              self._outputs.get(node), self._faults.get(node))

    def rows(self, event: Event) -> Rowed:
        kind = event.kind
        node = event.node_id
        simple = SIMPLE_ROWS.get(kind)
        if simple is not None:  # most of a fleet's log: other ECUs' frames
            return _new(Rowed, (node, self._model_of(node), simple))
        if kind is Kind.J1939:
            named = self._j1939_models.get(node) if node is not None else None
            model = named.model if named is not None and event.device is not None else \
                self._model_named(event.device)
            return _new(Rowed, (node, model, [self._j1939(event.fields)]))
        if kind is Kind.NMT:
            target = event.fields.get("target") or None
            return Rowed(target, self._model_of(target), [
                Detail("nmt", state=event.fields.get("command"), value=target)])
        model = self._model_of(node)
        if kind is Kind.PDO and node is not None:
            name = str(event.fields.get("pdo"))
            follow = self._pdo.get(name)
            if follow is not None:
                return _new(Rowed, (node, model, follow(node, event.fields)))
            return Rowed(node, model, [Detail("pdo", state=name, value=_only_int(event.fields))])
        if kind is Kind.HEARTBEAT:
            state = event.fields.get("state")
            details = self._heartbeats.get(state)
            if details is None:
                details = self._heartbeats[state] = [Detail("heartbeat", state=state)]
            return _new(Rowed, (node, model, details))
        if kind is Kind.BOOT_UP:
            self._reboot(node)
            return Rowed(node, model, [Detail("heartbeat", state="boot-up")])
        # SDO services: the kind of step as the state, the value where it is a number
        return _new(Rowed, (node, model, [_new(Detail, (
            "sdo", None, None, _NAMES[kind], None, _int_value(event.fields.get("value"))))]))

    # -- models -----------------------------------------------------------------------------

    def _model_of(self, node: int | None) -> str | None:
        if node is None:
            return None
        description = self._devices.get(node)
        return description.model if description is not None else None

    def _model_named(self, device: str | None) -> str | None:
        if device is None:
            return None
        model = self._models.get(device)
        if model is None:
            model = self._models[device] = describe_device(device).model
        return model

    # -- state followed ---------------------------------------------------------------------

    def _reboot(self, node: int | None) -> None:
        """Boot-up: LEDs dark, outputs OFF, no FAULT (the devices' power-on state)."""
        self.reads += 1
        for key in [k for k in self._leds if k[0] == node]:
            del self._leds[key]
        if node is not None:
            self._outputs.pop(node, None)
            self._faults.pop(node, None)
            if self._states.pop(node, None) is not None:
                self.changes += 1

    def _keys(self, node: int, fields: dict[str, Any]) -> list[Detail]:
        pressed, released = fields["pressed"], fields["released"]
        if not (pressed or released):
            return [_new(Detail, ("key", None, None, "held", None, len(fields["held"])))]
        return [_new(Detail, ("key", key, None, "pressed", None, None)) for key in pressed] + \
            [_new(Detail, ("key", key, None, "released", None, None)) for key in released]

    def _led_picture(self, node: int, fields: dict[str, Any]) -> list[Detail]:
        """A row per key whose colour changed (the picture as three masks, red, green and
        blue, of the keys lit: the changes are the bits that differ; a key's colour code is
        its red, green and blue bits, devices/colours.py)."""
        name = str(fields["pdo"])
        state = _LED_STATES[name]
        lit = (_mask(fields.get("red", ())), _mask(fields.get("green", ())),
               _mask(fields.get("blue", ())))
        place = (node, name)
        self.reads += 1
        before = self._leds.get(place, _DARK)
        changed = (lit[0] ^ before[0]) | (lit[1] ^ before[1]) | (lit[2] ^ before[2])
        if not changed:
            return [_LED_UNCHANGED]
        self._leds[place] = lit
        self._changed(node)
        red, green, blue = lit
        details = []
        for key in numbers(changed):
            bit = 1 << (key - 1)
            colour = _COLOUR_NAMES[(1 if red & bit else 0) | (2 if green & bit else 0)
                                   | (4 if blue & bit else 0)]
            details.append(_new(Detail, ("led", key, None, state, colour, None)))
        return details

    def _output_states(self, node: int, fields: dict[str, Any]) -> list[Detail]:
        """A row per pin that went HIGH or OFF (KBX §17: the decoder applied OFF wins)."""
        high = _mask(fields["high"])
        self.reads += 1
        changed = high ^ self._outputs.get(node, 0)
        if not changed:
            return [_OUTPUT_UNCHANGED]
        self._outputs[node] = high
        self._changed(node)
        return [_new(Detail, ("output", None, pin, "high" if high >> (pin - 1) & 1 else "off",
                              None, None)) for pin in numbers(changed)]

    def _fault_pins(self, node: int, fields: dict[str, Any]) -> list[Detail]:
        faults = fields["faults"]
        now = _mask(faults)
        self.reads += 1
        before = self._faults.get(node, 0)
        if node not in self._faults or now != before:
            self._faults[node] = now
            self._changed(node)
        if now == before:
            return [_new(Detail, ("fault", None, None, "unchanged", None, len(faults)))]
        return [_new(Detail, ("fault", None, pin, "fault", None, None))
                for pin in numbers(now & ~before)] + \
            [_new(Detail, ("fault", None, pin, "cleared", None, None))
             for pin in numbers(before & ~now)]

    # -- J1939 --------------------------------------------------------------------------------

    @staticmethod
    def _j1939(fields: dict[str, Any]) -> Detail:
        message, command = fields.get("message"), fields.get("command")
        if message == "key":
            return _new(Detail, ("key", fields["key"], None,
                                 "pressed" if fields["pressed"] else "released", None, None))
        if message == "heartbeat":  # spec/pkp-2600-si-j1939.md §18: counter and keys held
            return _new(Detail, ("heartbeat", None, None, "j1939", None, fields["counter"]))
        if command == "single_led":  # §7a
            state = LedState(fields["state"]).name.lower() if fields["state"] in \
                LedState._value2member_map_ else f"state {fields['state']:02X}h"
            return Detail("led", key=fields["key"], state=state,
                          colour=colour_name(fields["colour"]))
        return Detail("j1939", state=str(message or command or "address"),
                      value=_int_value(fields.get("value")))


def _only_int(fields: dict[str, Any]) -> int | None:
    """The value of a PDO with one numeric signal (a brightness level), else None."""
    values = [v for k, v in fields.items() if k != "pdo"]
    if len(values) == 1:
        value = values[0]
        if isinstance(value, float) and value.is_integer():
            return int(value)
        return _int_value(value)
    return None
