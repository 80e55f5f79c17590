"""EventRows' followers (fleet/rows.py: a PDO's rows straight from its bytes) make the rows
:meth:`EventRows.rows` makes of the frame's event, on layouts of any width: an LED picture's
colour codes read from its masks spread three bits a key (up to 16 keys) or key by key
(wider), outputs and faults by per-byte tables, a state that a wider layout of the same PDO
left (keys past the narrower one's width go dark). The registered models' layouts are
compared in tests/fleet/test_fast_rows.py; these are the widths no model has (yet)."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from blinkcan.decode import Decoder
from blinkcan.decode.decoder import Event, Kind, numbers
from blinkcan.devices.pdo import Direction, PdoLayout, PdoSignal
from blinkcan.fleet.rows import EventRows
from blinkcan.protocol import Frame

_NODE = 0x15


def _layout(name: str, widths: dict[str, int], item: str) -> PdoLayout:
    signals, start = [], 0
    for signal, width in widths.items():
        signals.append(PdoSignal(signal, signal, start, width, None, item=item))
        start += width
    return PdoLayout(name, name, 0x200, Direction.RX, (start + 7) // 8, tuple(signals))


def _event(layout: PdoLayout, data: bytes) -> Event:
    """The event the decoder's describer makes of a frame of ``layout`` (its masks as item
    numbers, the outputs as commanded: KBX §17, OFF wins)."""
    fields: dict[str, object] = {"pdo": layout.name}
    values = layout.decode(data)
    if layout.name == "outputs":
        values["high"] &= ~values["off"]
    fields.update((name, numbers(value)) for name, value in values.items())
    return Event(1.0, Frame(layout.cob_id(_NODE), data), Kind.PDO, "", _NODE, "keypad", fields)


def _led(width: int) -> PdoLayout:
    return _layout("led_on", {"red": width, "green": width, "blue": width}, "LED")


_LAYOUTS = {
    "led 12": [_led(12)], "led 16": [_led(16)], "led 21": [_led(21)],
    "led 16 after 21": [_led(21), _led(16)], "led 5 after 16": [_led(16), _led(5)],
    "outputs 13": [_layout("outputs", {"off": 13, "high": 13}, "pin")],
    "outputs 24": [_layout("outputs", {"off": 24, "high": 24}, "pin")],
    "faults 13": [_layout("faults", {"faults": 13}, "pin")],
    "faults 40": [_layout("faults", {"faults": 40}, "pin")],
    "faults 16 after 40": [_layout("faults", {"faults": 40}, "pin"),
                           _layout("faults", {"faults": 16}, "pin")],
}


@pytest.mark.parametrize("name", _LAYOUTS)
@given(data=st.data())
@settings(max_examples=60, deadline=None)
def test_a_followers_rows_are_its_events(name: str, data: st.DataObject) -> None:
    layouts = _LAYOUTS[name]
    decoder = Decoder()
    fast, reference = EventRows(decoder), EventRows(decoder)
    followers = [fast.follower(_NODE, layout) for layout in layouts]
    assert all(follow is not None for follow in followers)
    for _ in range(data.draw(st.integers(1, 30), label="frames")):
        which = data.draw(st.integers(0, len(layouts) - 1), label="layout")
        layout = layouts[which]
        picked = data.draw(st.sampled_from(("random", "random", "few")), label="picked")
        if picked == "random":
            payload = data.draw(st.binary(min_size=layout.length, max_size=layout.length))
        else:  # few values (pictures again, from the state they left)
            payload = bytes([data.draw(st.sampled_from((0, 1, 0xFF)))] * layout.length)
        follow = followers[which]
        assert follow is not None
        assert follow(payload) == reference.rows(_event(layout, payload)).details
