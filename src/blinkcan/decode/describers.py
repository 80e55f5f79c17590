"""What a PDO frame means: one describer per PDO kind, whose text and fields come from one place.

A describer turns the values of the signals it reads into ``(text, fields)``; the decoder makes
the event's one-line text and its JSON object from those two, so a wording is written once.
:func:`pdo_describer` binds one to a route (a PDO of one node): the signals are read by
precomputed shifts and masks, once per frame, and signals a short frame does not carry are
``None`` (errata P8: a key state of 2-4 bytes has no tick). PDOs with no describer of their own
are described from their layout alone (:func:`_generic`).
"""

from __future__ import annotations

from collections.abc import Callable
from functools import lru_cache
from typing import Any, NamedTuple

from blinkcan.devices.colours import BacklightColour
from blinkcan.devices.keybox import commanded_outputs
from blinkcan.devices.model import DeviceDescription
from blinkcan.devices.pdo import PdoLayout
from blinkcan.protocol.items import item_numbers

#: a frame's text and its fields (the JSON members after the text)
Described = tuple[str, dict[str, Any]]
#: a route's describer: the frame's data bytes -> what they mean
Describe = Callable[[bytes], Described]
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


class _Kind(NamedTuple):
    """A PDO kind with wording of its own: the signals its describer reads (those of
    ``required`` must be in the layout, the others are None where the layout lacks them) and
    the factory of the describer, given the node's description."""

    signals: tuple[str, ...]
    required: frozenset[str]
    make: Callable[[DeviceDescription, dict[int, int], int], Callable[..., Described]]


# -- the describers -----------------------------------------------------------------------------


def _key_state(description: DeviceDescription, held: dict[int, int], node: int
               ) -> Callable[..., Described]:
    """PKP §10: the keys pressed and released since the node's last key state (``held``)."""
    face_mask = (1 << description.face.keys) - 1

    def describe(keys: int, tick: int | None) -> Described:
        keys &= face_mask
        before = held.get(node, 0)
        held[node] = keys
        pressed, released = keys & ~before, before & ~keys
        if pressed and released:
            text = f"key {mask_listing(pressed)} pressed; key {mask_listing(released)} released"
        elif pressed:
            text = f"key {mask_listing(pressed)} pressed"
        elif released:
            text = f"key {mask_listing(released)} released"
        else:
            text = f"keys held: {mask_listing(keys)}"
        return text, {"pressed": numbers(pressed), "released": numbers(released),
                      "held": numbers(keys), "tick": tick}  # errata P8: 2-4 bytes, no tick

    return describe


def _leds(verb: str) -> Callable[[DeviceDescription, dict[int, int], int],
                                 Callable[..., Described]]:
    """PKP §11/§12: the keys lit (or blinking) in each colour."""
    def make(description: DeviceDescription, held: dict[int, int], node: int
             ) -> Callable[..., Described]:
        def describe(red: int, green: int, blue: int) -> Described:
            parts = [f"{colour} {mask_listing(mask)}" for colour, mask in
                     (("red", red), ("green", green), ("blue", blue)) if mask]
            return (f"{verb}: {'; '.join(parts) if parts else 'none'}",
                    {"red": numbers(red), "green": numbers(green), "blue": numbers(blue)})

        return describe

    return make


def _indicator(description: DeviceDescription, held: dict[int, int], node: int
               ) -> Callable[..., Described]:
    def describe(level: int) -> Described:  # PKP §13
        return f"indicator brightness {level}/63", {"level": level}

    return describe


def _backlight(description: DeviceDescription, held: dict[int, int], node: int
               ) -> Callable[..., Described]:
    def describe(level: int, code: int | None) -> Described:
        if level > 0x3F:
            return f"backlight level {level:02X}h over 3Fh: ignored", {"level": level}
        if code is None:  # rev 1.1 §14 (or a frame of one byte: the colour unchanged, G2)
            return f"backlight brightness {level}/63", {"level": level}
        # rev 1.5 §15: byte 1 is the colour, 00h the default one
        colour = BacklightColour(code).label if BacklightColour.is_code(code) else \
            "the default colour"
        return f"backlight {level}/63 in {colour}", {"level": level, "colour": colour}

    return describe


def _outputs(description: DeviceDescription, held: dict[int, int], node: int
             ) -> Callable[..., Described]:
    def describe(off: int, high: int) -> Described:
        off, high = commanded_outputs(off, high)  # KBX §17: OFF wins (devices/keybox.py)
        return (f"outputs OFF: {mask_listing(off)}; HIGH: {mask_listing(high)}",
                {"off": numbers(off), "high": numbers(high)})

    return describe


def _faults(description: DeviceDescription, held: dict[int, int], node: int
            ) -> Callable[..., Described]:
    def describe(faults: int) -> Described:  # KBX §18
        return f"outputs in FAULT: {mask_listing(faults)}", {"faults": numbers(faults)}

    return describe


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


def _generic(layout: PdoLayout) -> Callable[..., Described]:
    """Any PDO from its layout alone: masks as item numbers, values scaled to their unit."""
    signals = layout.signals
    label = layout.label.lower()

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
                shown = f"{value:g} {signal.unit}" if signal.unit else f"{value}"
                parts.append(f"{signal.label.lower()} {shown}")
        return f"{label}: {', '.join(parts)}", fields

    return describe


def keyed_signal(layout: PdoLayout) -> tuple[int, int] | None:
    """(shift, mask) of the keys of a key-state PDO, whose meaning depends on the keys held
    before; None for a PDO whose meaning is its bytes alone."""
    if layout.name != "key_state":
        return None
    keys = layout.signal("keys")
    return keys.start, keys.mask


def pdo_describer(layout: PdoLayout, description: DeviceDescription, node: int,
                  held: dict[int, int]) -> Describe:
    """The describer of ``layout``'s frames from ``node``: data bytes -> (text, fields).
    ``held`` is the decoder's memory of each node's keys (read and written by key states).
    Frames shorter than the layout's ``min_length`` are the caller's to refuse."""
    by_name = {s.name: s for s in layout.signals}
    kind = _KINDS.get(layout.name)
    if kind is not None and kind.required <= by_name.keys():
        describe = kind.make(description, held, node)
        read = [by_name.get(name) for name in kind.signals]
    else:
        describe = _generic(layout)
        read = list(layout.signals)
    # (shift, mask) per value; a signal the layout lacks reads as absent (None)
    slots = [(s.start, s.mask) if s is not None else (-1, 0) for s in read]
    length = layout.length
    if all(start >= 0 for start, _ in slots) and len(slots) <= 3:
        (s0, m0), (s1, m1), (s2, m2) = (slots + [(0, 0)] * 3)[:3]
        count = len(slots)
        full: Callable[[int], Described]
        if count == 1:
            def full(word: int) -> Described:
                return describe((word >> s0) & m0)
        elif count == 2:
            def full(word: int) -> Described:
                return describe((word >> s0) & m0, (word >> s1) & m1)
        else:
            def full(word: int) -> Described:
                return describe((word >> s0) & m0, (word >> s1) & m1, (word >> s2) & m2)
    else:
        def full(word: int) -> Described:
            return describe(*[(word >> start) & mask if start >= 0 else None
                              for start, mask in slots])

    def route(data: bytes) -> Described:
        word = int.from_bytes(data, "little")
        if len(data) >= length:  # the common case: every signal there
            return full(word)
        bits = 8 * len(data)  # signals the frame does not carry are absent
        return describe(*[(word >> start) & mask if 0 <= start < bits else None
                          for start, mask in slots])

    return route
