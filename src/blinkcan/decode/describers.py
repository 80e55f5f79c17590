"""What a PDO frame means: one describer per PDO kind, whose text and fields come from one place.

A describer turns the values of the signals it reads into ``(text, fields)``; the decoder makes
the event's one-line text and its JSON object from those two, so a wording is written once.
:func:`pdo_describer` binds one to a route (a PDO of one node): the signals are read by
precomputed shifts and masks, once per frame, and signals a short frame does not carry are
``None`` (errata P8: a key state of 2-4 bytes has no tick). PDOs with no describer of their own
are described from their layout alone (:func:`_generic`).

``decode --json`` wants only the JSON line: :func:`pdo_json_describer` gives the same text and
the fields already written as JSON members (masks through per-byte tables, no list, no dict),
from the same wording helpers (tests/decode/test_json_writers.py compares the two renderings
over every registered model's layouts). ``decode``'s text and the fleet's rows want only the
text: :func:`pdo_text_describer` gives it, the wording alone where a kind has one (LED
pictures, outputs, faults, brightness: no list of item numbers), else the JSON one's text.
"""

from __future__ import annotations

from collections.abc import Callable
from functools import lru_cache
from typing import Any, NamedTuple, TypeVar

import orjson

from blinkcan.devices.colours import BacklightColour
from blinkcan.devices.keybox import commanded_outputs
from blinkcan.devices.model import DeviceDescription
from blinkcan.devices.pdo import PdoLayout, PdoSignal
from blinkcan.protocol.items import item_numbers

_dumps = orjson.dumps
_T = TypeVar("_T")

#: a frame's text and its fields (the JSON members after the text)
Described = tuple[str, dict[str, Any]]
#: a route's describer: the frame's data bytes -> what they mean
Describe = Callable[[bytes], Described]
#: a frame's text and its fields as JSON members (``"level":3,"colour":"red"``)
DescribedJson = tuple[str, str]
#: a route's JSON describer: a frame's data bytes (all the layout's) -> its text, JSON fields
DescribeJson = Callable[[bytes], DescribedJson]
#: masks whose item numbers and listing are kept (key, LED and pin masks are 12-24 bits, so a
#: log's masks are found again; a bounded cache keeps memory flat on random ones)
_MASKS_KEPT = 8192


@lru_cache(maxsize=8)
def _byte_items(position: int) -> tuple[tuple[int, ...], ...]:
    """Per value of byte ``position`` of a mask: the item numbers its bits are (bit 0 = item
    1). Made when first needed (start-up: most runs never need a mask's third byte)."""
    return tuple(tuple(8 * position + bit + 1 for bit in range(8) if value >> bit & 1)
                 for value in range(256))


@lru_cache(maxsize=8)
def _byte_text(position: int) -> tuple[str, ...]:
    """The same as text ("9, 12"), empty for a byte with no bit set."""
    return tuple(", ".join(map(str, items)) for items in _byte_items(position))


@lru_cache(maxsize=8)
def _byte_json(position: int) -> tuple[str, ...]:
    """The same as JSON list members ("9,12")."""
    return tuple(",".join(map(str, items)) for items in _byte_items(position))


def _mask_json(mask: int) -> str:
    """The JSON list of :func:`numbers` of any mask."""
    return f"[{','.join(map(str, numbers(mask)))}]"


def _mask_writers(width: int) -> tuple[Callable[[int], str], Callable[[int], str]]:
    """(:func:`mask_listing`, the JSON list of :func:`numbers`) for masks of a signal of
    ``width`` bits, read through per-byte tables (a log's LED and key masks are too many to
    cache); a wider mask (a node's keys before its model changed) the general way."""
    if width > 16:
        return mask_listing, _mask_json
    text0, text1, json0, json1 = _byte_text(0), _byte_text(1), _byte_json(0), _byte_json(1)

    def listing16(mask: int) -> str:
        if mask >> 16 or mask < 0:
            return mask_listing(mask)
        low, high = text0[mask & 0xFF], text1[mask >> 8]
        if low and high:
            return f"{low}, {high}"
        return low or high or "none"

    def json16(mask: int) -> str:
        if mask >> 16 or mask < 0:
            return _mask_json(mask)
        low, high = json0[mask & 0xFF], json1[mask >> 8]
        return f"[{low},{high}]" if low and high else f"[{low or high}]"

    return listing16, json16


@lru_cache(maxsize=_MASKS_KEPT)
def _items(mask: int) -> tuple[int, ...]:
    if mask >> 64:
        return tuple(item_numbers(mask))
    found: tuple[int, ...] = ()
    position = 0
    while mask:  # a byte at a time: a table lookup each
        found += _byte_items(position)[mask & 0xFF]
        mask >>= 8
        position += 1
    return found


def mask_items(width: int) -> Callable[[int], tuple[int, ...] | list[int]]:
    """:func:`numbers` (as a tuple) for masks of a signal of ``width`` bits, through two
    per-byte tables and no cache (a log's random LED pictures would only churn it); a wider
    mask, or another, the general way."""
    if width > 16:
        return numbers
    low, high = _byte_items(0), _byte_items(1)

    def items16(mask: int) -> tuple[int, ...] | list[int]:
        if mask >> 16 or mask < 0:
            return numbers(mask)
        return low[mask & 0xFF] + high[mask >> 8]

    return items16


def numbers(mask: int, offset: int = 1) -> list[int]:
    """[1, 4, 12] for the set bits of a mask (bit 0 = item ``offset``)."""
    if offset == 1 and mask >= 0:
        return list(_items(mask))
    return item_numbers(mask, offset)


def listing(items: list[int]) -> str:
    return ", ".join(map(str, items)) if items else "none"


@lru_cache(maxsize=_MASKS_KEPT)
def mask_listing(mask: int) -> str:
    """``listing(numbers(mask))``, one lookup for a mask seen before."""
    if mask < 0 or mask >> 64:
        return listing(numbers(mask))
    parts = []
    position = 0
    while mask:  # a byte at a time: a table lookup each
        if mask & 0xFF:
            parts.append(_byte_text(position)[mask & 0xFF])
        mask >>= 8
        position += 1
    return ", ".join(parts) if parts else "none"


#: a kind's renderings of a frame's signal values: its (text, fields) and (text, JSON), and
#: where the kind has one its text alone (the same wording: one function makes it for all
#: three; a key state's moves the keys held as the others do); a kind without has two
_Pair = tuple[Callable[..., Any], ...]
#: a route's text describer: the frame's data bytes (at least the layout's shortest) -> its text
DescribeText = Callable[[bytes], str]


def _json_members(fields: dict[str, Any]) -> str:
    """Fields as JSON object members, as orjson writes them (no braces)."""
    return _dumps(fields)[1:-1].decode()


class _Kind(NamedTuple):
    """A PDO kind with wording of its own: the signals its describer reads (those of
    ``required`` must be in the layout, the others are None where the layout lacks them) and
    the factory of its two renderings, given the node's description and the widths of the
    signals read: the describer, and the JSON one (for frames with every signal)."""

    signals: tuple[str, ...]
    required: frozenset[str]
    make: Callable[[DeviceDescription, dict[int, int], int, tuple[int, ...]], _Pair]


# -- the describers -----------------------------------------------------------------------------


def _key_state(description: DeviceDescription, held: dict[int, int], node: int,
               widths: tuple[int, ...]) -> _Pair:
    """PKP §10: the keys pressed and released since the node's last key state (``held``)."""
    face_mask = (1 << description.face.keys) - 1
    listing, as_json = _mask_writers(description.face.keys)

    def change(keys: int) -> tuple[str, int, int]:
        """The text of the keys now, and (pressed, released); the keys remembered."""
        before = held.get(node, 0)
        held[node] = keys
        pressed, released = keys & ~before, before & ~keys
        if pressed and released:
            text = f"key {listing(pressed)} pressed; key {listing(released)} released"
        elif pressed:
            text = f"key {listing(pressed)} pressed"
        elif released:
            text = f"key {listing(released)} released"
        else:
            text = f"keys held: {listing(keys)}"
        return text, pressed, released

    def describe(keys: int, tick: int | None) -> Described:
        keys &= face_mask
        text, pressed, released = change(keys)
        return text, {"pressed": numbers(pressed), "released": numbers(released),
                      "held": numbers(keys), "tick": tick}  # errata P8: 2-4 bytes, no tick

    def describe_json(keys: int, tick: int | None) -> DescribedJson:
        keys &= face_mask
        text, pressed, released = change(keys)
        return text, (f'"pressed":{as_json(pressed)},"released":{as_json(released)},'
                      f'"held":{as_json(keys)},"tick":{"null" if tick is None else tick}')

    def text(keys: int, tick: int | None) -> str:
        return change(keys & face_mask)[0]

    return describe, describe_json, text


def _leds(verb: str) -> Callable[[DeviceDescription, dict[int, int], int, tuple[int, ...]],
                                 _Pair]:
    """PKP §11/§12: the keys lit (or blinking) in each colour."""
    def make(description: DeviceDescription, held: dict[int, int], node: int,
             widths: tuple[int, ...]) -> _Pair:
        listing, as_json = _mask_writers(max(widths))

        def text(red: int, green: int, blue: int) -> str:
            parts = [f"{colour} {listing(mask)}" for colour, mask in
                     (("red", red), ("green", green), ("blue", blue)) if mask]
            return f"{verb}: {'; '.join(parts) if parts else 'none'}"

        def describe(red: int, green: int, blue: int) -> Described:
            return (text(red, green, blue),
                    {"red": numbers(red), "green": numbers(green), "blue": numbers(blue)})

        def describe_json(red: int, green: int, blue: int) -> DescribedJson:
            return (text(red, green, blue),
                    f'"red":{as_json(red)},"green":{as_json(green)},"blue":{as_json(blue)}')

        return describe, describe_json, text

    return make


def _indicator(description: DeviceDescription, held: dict[int, int], node: int,
               widths: tuple[int, ...]) -> _Pair:
    def text(level: int) -> str:  # PKP §13
        return f"indicator brightness {level}/63"

    def describe(level: int) -> Described:
        return text(level), {"level": level}

    def describe_json(level: int) -> DescribedJson:
        return text(level), f'"level":{level}'

    return describe, describe_json, text


def _backlight(description: DeviceDescription, held: dict[int, int], node: int,
               widths: tuple[int, ...]) -> _Pair:
    def describe(level: int, code: int | None) -> Described:
        if level > 0x3F:
            return f"backlight level {level:02X}h over 3Fh: ignored", {"level": level}
        if code is None:  # rev 1.1 §14 (or a frame of one byte: the colour unchanged, G2)
            return f"backlight brightness {level}/63", {"level": level}
        # rev 1.5 §15: byte 1 is the colour, 00h the default one
        colour = BacklightColour(code).label if BacklightColour.is_code(code) else \
            "the default colour"
        return f"backlight {level}/63 in {colour}", {"level": level, "colour": colour}

    def describe_json(level: int, code: int | None) -> DescribedJson:
        text, fields = describe(level, code)
        return text, _json_members(fields)

    return describe, describe_json


def _outputs(description: DeviceDescription, held: dict[int, int], node: int,
             widths: tuple[int, ...]) -> _Pair:
    listing, as_json = _mask_writers(max(widths))

    def words(off: int, high: int) -> str:  # (the commanded masks)
        return f"outputs OFF: {listing(off)}; HIGH: {listing(high)}"

    def text(off: int, high: int) -> str:
        return words(*commanded_outputs(off, high))

    def describe(off: int, high: int) -> Described:
        off, high = commanded_outputs(off, high)  # KBX §17: OFF wins (devices/keybox.py)
        return words(off, high), {"off": numbers(off), "high": numbers(high)}

    def describe_json(off: int, high: int) -> DescribedJson:
        off, high = commanded_outputs(off, high)
        return words(off, high), f'"off":{as_json(off)},"high":{as_json(high)}'

    return describe, describe_json, text


def _faults(description: DeviceDescription, held: dict[int, int], node: int,
            widths: tuple[int, ...]) -> _Pair:
    listing, as_json = _mask_writers(max(widths))

    def text(faults: int) -> str:  # KBX §18
        return f"outputs in FAULT: {listing(faults)}"

    def describe(faults: int) -> Described:
        return text(faults), {"faults": numbers(faults)}

    def describe_json(faults: int) -> DescribedJson:
        return text(faults), f'"faults":{as_json(faults)}'

    return describe, describe_json, text


#: the PDOs with wording of their own, by layout name
_KINDS: dict[str, _Kind] = {
    "key_state": _Kind(("keys", "tick"), frozenset({"keys"}), _key_state),
    "led_on": _Kind(("red", "green", "blue"), frozenset({"red", "green", "blue"}),
                    _leds("LEDs on")),
    "led_blink": _Kind(("red", "green", "blue"), frozenset({"red", "green", "blue"}),
                       _leds("LEDs blink")),
    "indicator_brightness": _Kind(("level",), frozenset({"level"}), _indicator),
    "backlight_brightness": _Kind(("level", "colour"), frozenset({"level"}), _backlight),
    "outputs": _Kind(("off", "high"), frozenset({"off", "high"}), _outputs),
    "faults": _Kind(("faults",), frozenset({"faults"}), _faults),
}


def _shown(signal: PdoSignal, value: int | float) -> str:
    """A signal's physical value as a generic PDO's text writes it."""
    return f"{signal.label.lower()} {value:g} {signal.unit}" if signal.unit else \
        f"{signal.label.lower()} {value}"


def _generic(layout: PdoLayout) -> _Pair:
    """Any PDO from its layout alone: masks as item numbers, values scaled to their unit."""
    signals = layout.signals
    label = layout.label.lower()
    members = [_dumps(signal.name).decode() + ":" for signal in signals]
    masks = [_mask_writers(signal.length)[1] for signal in signals]

    def describe(*values: int | None) -> Described:
        parts: list[str] = []
        fields: dict[str, Any] = {}
        for signal, raw in zip(signals, values, strict=False):
            if raw is None:
                continue
            if signal.item is not None:
                items = numbers(raw)
                fields[signal.name] = items
                parts.append(f"{signal.item} {listing(items)}")
            else:
                value = signal.physical(raw)
                fields[signal.name] = value
                parts.append(_shown(signal, value))
        return f"{label}: {', '.join(parts)}", fields

    def describe_json(*values: int | None) -> DescribedJson:
        parts: list[str] = []
        written: list[str] = []
        for signal, raw, member, mask_json in zip(signals, values, members, masks, strict=False):
            if raw is None:
                continue
            if signal.item is not None:
                parts.append(f"{signal.item} {mask_listing(raw)}")
                written.append(member + mask_json(raw))
            else:
                value = signal.physical(raw)
                parts.append(_shown(signal, value))
                written.append(member + (str(value) if type(value) is int else
                                         _dumps(value).decode()))
        return f"{label}: {', '.join(parts)}", ",".join(written)

    return describe, describe_json


def keyed_signal(layout: PdoLayout) -> tuple[int, int] | None:
    """(shift, mask) of the keys of a key-state PDO, whose meaning depends on the keys held
    before; None for a PDO whose meaning is its bytes alone."""
    if layout.name != "key_state":
        return None
    keys = layout.signal("keys")
    return keys.start, keys.mask


def _reader(slots: list[tuple[int, int]], length: int, describe: Callable[..., _T]
            ) -> Callable[[bytes], _T]:
    """``describe`` of the values a frame's data carries at ``slots`` (shift, mask; a shift of
    -1: a signal the layout lacks, None); a signal a frame shorter than ``length`` does not
    carry is None too."""
    def partial(data: bytes) -> _T:
        word, bits = int.from_bytes(data, "little"), 8 * len(data)
        return describe(*[(word >> start) & mask if 0 <= start < bits else None
                          for start, mask in slots])

    if not all(start >= 0 for start, _ in slots) or len(slots) > 3:
        return partial
    (s0, m0), (s1, m1), (s2, m2) = (slots + [(0, 0)] * 3)[:3]
    count = len(slots)
    from_bytes = int.from_bytes
    # the common case, every signal there, without a loop
    if count == 1:
        def full(data: bytes) -> _T:
            if len(data) < length:
                return partial(data)
            return describe((from_bytes(data, "little") >> s0) & m0)
    elif count == 2:
        def full(data: bytes) -> _T:
            if len(data) < length:
                return partial(data)
            word = from_bytes(data, "little")
            return describe((word >> s0) & m0, (word >> s1) & m1)
    else:
        def full(data: bytes) -> _T:
            if len(data) < length:
                return partial(data)
            word = from_bytes(data, "little")
            return describe((word >> s0) & m0, (word >> s1) & m1, (word >> s2) & m2)
    return full


def pdo_renderings(layout: PdoLayout, description: DeviceDescription, node: int,
                   held: dict[int, int]) -> tuple[Describe, DescribeJson, DescribeText]:
    """The describers of ``layout``'s frames from ``node``: data bytes -> (text, fields),
    data bytes -> (text, fields as JSON members), and data bytes -> the text alone. ``held``
    is the decoder's memory of each node's keys (read and written by key states: each of the
    three moves them, so one of them is called per frame). Frames shorter than the layout's
    ``min_length`` are the caller's to refuse."""
    by_name = {s.name: s for s in layout.signals}
    kind = _KINDS.get(layout.name)
    read: list[PdoSignal | None]
    if kind is not None and kind.required <= by_name.keys():
        read = [by_name.get(name) for name in kind.signals]
        renderings = kind.make(description, held, node, tuple(
            s.length for s in read if s is not None))
    else:
        renderings = _generic(layout)
        read = list(layout.signals)
    # (shift, mask) per value; a signal the layout lacks reads as absent (None)
    slots = [(s.start, s.mask) if s is not None else (-1, 0) for s in read]
    describe: Describe = _reader(slots, layout.length, renderings[0])
    describe_json: DescribeJson = _reader(slots, layout.length, renderings[1])
    if len(renderings) > 2:
        text: DescribeText = _reader(slots, layout.length, renderings[2])
    else:
        def text(data: bytes) -> str:
            return describe_json(data)[0]
    return describe, describe_json, text


def pdo_describers(layout: PdoLayout, description: DeviceDescription, node: int,
                   held: dict[int, int]) -> tuple[Describe, DescribeJson]:
    """The first two of :func:`pdo_renderings`: data bytes -> (text, fields), and data
    bytes -> (text, fields as JSON members)."""
    return pdo_renderings(layout, description, node, held)[:2]


def pdo_describer(layout: PdoLayout, description: DeviceDescription, node: int,
                  held: dict[int, int]) -> Describe:
    """The first of :func:`pdo_renderings`: data bytes -> (text, fields)."""
    return pdo_renderings(layout, description, node, held)[0]


def pdo_text_describer(layout: PdoLayout, description: DeviceDescription, node: int,
                       held: dict[int, int]) -> DescribeText:
    """The last of :func:`pdo_renderings`: data bytes -> the text alone."""
    return pdo_renderings(layout, description, node, held)[2]
