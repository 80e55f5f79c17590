"""Decoder events as table rows: what each event says about keys, LEDs, outputs and faults.

One event can be several rows (a key-state frame that presses two keys is two ``key`` rows)
and is always at least one, so every frame of a log is in the table. Where a frame repeats
a device's state (the Keybox's periodic fault message, KBX §25; an LED frame sent again), the
row says ``unchanged`` rather than repeating the pins or keys: a ``fault`` row with a pin is a
pin that went into FAULT (``fault``) or out of it (``cleared``), so counting them counts fuse
blows. The state followed per node starts where the devices start (LEDs dark, outputs OFF, no
FAULT) and restarts at each boot-up. No pyarrow here: the rows are plain tuples.

Two ways to the same rows: :meth:`EventRows.rows` reads any event's fields (the reference),
and :meth:`EventRows.follower` compiles, for one PDO of one node whose rows follow a state
(LEDs, outputs, faults), a function from the frame's data bytes to its rows: the signals read
by the layout's shifts and masks, compared as masks with the state, and each row a prebuilt
detail (most of a fleet's device rows; tests/fleet/test_fast_rows.py compares the two).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, NamedTuple

from blinkcan.decode.decoder import Decoder, Event, Kind, numbers
from blinkcan.decode.describers import mask_items
from blinkcan.decode.j1939 import colour_name
from blinkcan.devices.colours import channel_name
from blinkcan.devices.keybox import commanded_outputs
from blinkcan.devices.keypad_j1939 import LedState
from blinkcan.devices.pdo import PdoLayout
from blinkcan.devices.registry import describe_device

#: the event kinds of the table, in the order the schema documents them
KINDS = ("key", "led", "output", "fault", "heartbeat", "nmt", "sdo", "j1939", "pdo", "sync",
         "remote", "error", "undecoded", "unreadable")
_DARK = (0, 0, 0)
_LED_STATES = {"led_on": "on", "led_blink": "blink"}
_COLOUR_NAMES = tuple(channel_name(channels) for channels in range(8))
_NAMES = {kind: kind.value for kind in Kind}  # an Enum's value is a slow property
#: a J1939 single-LED command's state byte as a row's state (§7a; an Enum call is slow)
_J1939_LED_STATES = {state.value: state.name.lower() for state in LedState}


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
#: a follower: the data bytes of a frame of its layout's length (or longer) -> its rows (a
#: shorter one's signals are not all there: EventRows.rows reads its event)
#: the item numbers a mask of a frame's 8 bytes can name, 0 included (a follower's tables of
#: rows by key or pin cover them all: the state may hold a mask another layout wrote)
_ITEMS = range(65)
Follower = Callable[[bytes], "list[Detail]"]
_new = tuple.__new__  # a Detail without the call to its __new__: many rows are made
#: per byte value: its bits spread three apart (bit i at bit 3i), so that three masks spread
#: and or-ed (red, green shifted by one, blue by two) hold each key's colour code (red, green
#: and blue bits, devices/colours.py) at bit 3 * (key - 1)
_SPREAD = tuple(sum((value >> bit & 1) << 3 * bit for bit in range(8)) for value in range(256))


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
        self._models: dict[str, str] = {}
        self._heartbeats: dict[object, list[Detail]] = {}  # state -> its row (shared)
        self._pdo: dict[str, Callable[[int, dict[str, Any]], list[Detail]]] = {
            "key_state": self._keys, "led_on": self._led_picture,
            "led_blink": self._led_picture, "outputs": self._output_states,
            "faults": self._fault_pins,
        }

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
            return Rowed(node, model, [self.pdo_detail(name, event.fields)])
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

    def follows(self, pdo: str) -> bool:
        """Whether the rows of the PDO named ``pdo`` follow a state (:meth:`follower`), or
        are its one :meth:`pdo_detail`."""
        return pdo in self._pdo

    @staticmethod
    def pdo_detail(pdo: str, fields: dict[str, Any]) -> Detail:
        """The one row of a PDO whose rows follow nothing, from its describer's fields (the
        event's, ``pdo`` among them or not): its name, and its value where it has one number
        (a brightness level)."""
        return _new(Detail, ("pdo", None, None, pdo, None, _only_int(fields)))

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
        for key in [k for k in self._leds if k[0] == node]:
            del self._leds[key]
        if node is not None:
            self._outputs.pop(node, None)
            self._faults.pop(node, None)

    def _keys(self, node: int, fields: dict[str, Any]) -> list[Detail]:
        return key_rows(_mask(fields["pressed"]), _mask(fields["released"]),
                        len(fields["held"]))

    def _led_picture(self, node: int, fields: dict[str, Any]) -> list[Detail]:
        """A row per key whose colour changed (the picture as three masks, red, green and
        blue, of the keys lit: the changes are the bits that differ; a key's colour code is
        its red, green and blue bits, devices/colours.py)."""
        name = str(fields["pdo"])
        state = _LED_STATES[name]
        lit = (_mask(fields.get("red", ())), _mask(fields.get("green", ())),
               _mask(fields.get("blue", ())))
        place = (node, name)
        before = self._leds.get(place, _DARK)
        changed = (lit[0] ^ before[0]) | (lit[1] ^ before[1]) | (lit[2] ^ before[2])
        if not changed:
            return [_LED_UNCHANGED]
        self._leds[place] = lit
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
        changed = high ^ self._outputs.get(node, 0)
        if not changed:
            return [_OUTPUT_UNCHANGED]
        self._outputs[node] = high
        return [_new(Detail, ("output", None, pin, "high" if high >> (pin - 1) & 1 else "off",
                              None, None)) for pin in numbers(changed)]

    def _fault_pins(self, node: int, fields: dict[str, Any]) -> list[Detail]:
        faults = fields["faults"]
        now = _mask(faults)
        before = self._faults.get(node, 0)
        self._faults[node] = now
        if now == before:
            return [_new(Detail, ("fault", None, None, "unchanged", None, len(faults)))]
        return [_new(Detail, ("fault", None, pin, "fault", None, None))
                for pin in numbers(now & ~before)] + \
            [_new(Detail, ("fault", None, pin, "cleared", None, None))
             for pin in numbers(before & ~now)]

    # -- followers: a PDO's rows straight from its bytes ----------------------------------------

    def follower(self, node: int, layout: PdoLayout) -> Follower | None:
        """The rows of ``layout``'s frames from ``node`` straight from their data bytes: the
        same rows :meth:`rows` makes of their events, for the PDOs whose rows follow a state
        (LED pictures, outputs, faults); None for the others. The signals are read as the
        decoder's describer reads them (decode/describers.py: the word's shifts and masks,
        a layout with the signals its wording needs), and the state is this object's, so
        both ways may take turns on one log. The follower takes frames of the layout's
        length or longer (a shorter one lacks signals: its event's way)."""
        signals = {s.name: (s.start, s.mask) for s in layout.signals}
        name = layout.name
        if name in _LED_STATES and {"red", "green", "blue"} <= signals.keys():
            return self._picture_follower(node, name, signals["red"],
                                          signals["green"], signals["blue"])
        if name == "outputs" and {"off", "high"} <= signals.keys():
            return self._outputs_follower(node, signals["off"], signals["high"])
        if name == "faults" and "faults" in signals:
            return self._faults_follower(node, signals["faults"])
        return None

    def _picture_follower(self, node: int, name: str, red: tuple[int, int],
                          green: tuple[int, int], blue: tuple[int, int]) -> Follower:
        """:meth:`_led_picture` from the bytes: a row per key whose colour changed, each row
        one of a table by key and colour code (red, green and blue bits)."""
        leds, place, state = self._leds, (node, name), _LED_STATES[name]
        (red_at, red_mask), (green_at, green_mask), (blue_at, blue_mask) = red, green, blue
        table = [_new(Detail, ("led", key, None, state, _COLOUR_NAMES[code], None))
                 for key in _ITEMS[1:] for code in range(8)]  # (key - 1) * 8 + code
        unchanged = [_LED_UNCHANGED]  # shared: rows are never changed
        width = max(red_mask, green_mask, blue_mask).bit_length()
        if width > 16:
            def follow(data: bytes) -> list[Detail]:
                word = int.from_bytes(data, "little")
                lit = (word >> red_at & red_mask, word >> green_at & green_mask,
                       word >> blue_at & blue_mask)
                before = leds.get(place, _DARK)
                changed = (lit[0] ^ before[0]) | (lit[1] ^ before[1]) | (lit[2] ^ before[2])
                if not changed:
                    return unchanged
                leds[place] = lit
                r, g, b = lit
                return [table[(key - 1) * 8 | (r >> (key - 1) & 1) | (g >> (key - 1) & 1) << 1
                              | (b >> (key - 1) & 1) << 2] for key in numbers(changed)]

            return follow
        # up to 16 keys (every registered keypad): each key's colour code read from the
        # three masks spread (_SPREAD), its rows by key and code (a key past the picture's
        # width, lit by another layout before, goes dark: code 0)
        by_key = [table[(key - 1) * 8:key * 8] for key in _ITEMS]  # by_key[key][code]
        items, spread, from_bytes = mask_items(16), _SPREAD, int.from_bytes

        def follow16(data: bytes) -> list[Detail]:
            word = from_bytes(data, "little")
            r, g, b = (word >> red_at & red_mask, word >> green_at & green_mask,
                       word >> blue_at & blue_mask)
            before = leds.get(place, _DARK)
            changed = (r ^ before[0]) | (g ^ before[1]) | (b ^ before[2])
            if not changed:
                return unchanged
            leds[place] = (r, g, b)
            codes = (spread[r & 0xFF] | spread[r >> 8] << 24) | (
                spread[g & 0xFF] | spread[g >> 8] << 24) << 1 | (
                spread[b & 0xFF] | spread[b >> 8] << 24) << 2
            return [by_key[key][codes >> 3 * key - 3 & 7] for key in items(changed)]

        return follow16

    def _outputs_follower(self, node: int, off: tuple[int, int],
                          high: tuple[int, int]) -> Follower:
        """:meth:`_output_states` from the bytes (KBX §17: OFF wins, devices/keybox.py)."""
        outputs = self._outputs
        (off_at, off_mask), (high_at, high_mask) = off, high
        went_high = [_new(Detail, ("output", None, pin, "high", None, None)) for pin in _ITEMS]
        went_off = [_new(Detail, ("output", None, pin, "off", None, None)) for pin in _ITEMS]
        unchanged = [_OUTPUT_UNCHANGED]
        items = mask_items(16)

        def follow(data: bytes) -> list[Detail]:
            word = int.from_bytes(data, "little")
            _, now = commanded_outputs(word >> off_at & off_mask, word >> high_at & high_mask)
            changed = now ^ outputs.get(node, 0)
            if not changed:
                return unchanged
            outputs[node] = now
            return [(went_high if now >> (pin - 1) & 1 else went_off)[pin]
                    for pin in items(changed)]

        return follow

    def _faults_follower(self, node: int, signal: tuple[int, int]) -> Follower:
        """:meth:`_fault_pins` from the bytes: the pins that went into FAULT and out of it,
        or the one ``unchanged`` row with the count of pins in FAULT (KBX §25)."""
        faults = self._faults
        at, mask = signal
        went_in = [_new(Detail, ("fault", None, pin, "fault", None, None)) for pin in _ITEMS]
        went_out = [_new(Detail, ("fault", None, pin, "cleared", None, None)) for pin in _ITEMS]
        unchanged = [[_new(Detail, ("fault", None, None, "unchanged", None, count))]
                     for count in _ITEMS]  # by the count of pins in FAULT
        items = mask_items(16)

        def follow(data: bytes) -> list[Detail]:
            now = int.from_bytes(data, "little") >> at & mask
            before = faults.get(node, 0)
            faults[node] = now
            if now == before:
                return unchanged[bin(now).count("1")]
            return [went_in[pin] for pin in items(now & ~before)] + \
                [went_out[pin] for pin in items(before & ~now)]

        return follow

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
            code = fields["state"]
            state = _J1939_LED_STATES.get(code) or f"state {code:02X}h"
            return _new(Detail, ("led", fields["key"], None, state, colour_name(fields["colour"]),
                                 None))
        return _new(Detail, ("j1939", None, None, str(message or command or "address"), None,
                             _int_value(fields.get("value"))))


_PRESSED = tuple(Detail("key", key, state="pressed") for key in _ITEMS)
_RELEASED = tuple(Detail("key", key, state="released") for key in _ITEMS)
#: the keys of a mask (a keypad has at most 16: per-byte tables, no cache)
_key_items = mask_items(16)


def key_rows(pressed: int, released: int, held: int) -> list[Detail]:
    """The rows of a key state (PKP §10) from the masks of the keys pressed and released
    since the last one (bit 0 is key 1): a row per key pressed, then per key released; or,
    where none was, the one ``held`` row with the count of keys held."""
    if not (pressed or released):
        return [_new(Detail, ("key", None, None, "held", None, held))]
    return [_PRESSED[key] for key in _key_items(pressed)] + \
        [_RELEASED[key] for key in _key_items(released)]


def _only_int(fields: dict[str, Any]) -> int | None:
    """The value of a PDO with one numeric signal (a brightness level), else None."""
    values = [v for k, v in fields.items() if k != "pdo"]
    if len(values) == 1:
        value = values[0]
        if isinstance(value, float) and value.is_integer():
            return int(value)
        return _int_value(value)
    return None
