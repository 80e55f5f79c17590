"""Events into rows: what changed is a row per key or pin, a repeat is one "unchanged" row,
a boot-up starts the picture again; times no timestamp carries have no date."""

from __future__ import annotations

import math

import pyarrow as pa
import pytest
from fsspec.implementations.memory import MemoryFileSystem
from hypothesis import given, settings
from hypothesis import strategies as st

from blinkcan.decode import Decoder
from blinkcan.devices.keypad_j1939 import (
    COLOUR_CODES,
    COMMANDS,
    DEFAULT_ADDRESS,
    DEFAULT_HOST_ADDRESS,
    PRIORITY,
    LedState,
)
from blinkcan.devices.registry import describe_device
from blinkcan.fleet.rows import Detail, EventRows
from blinkcan.fleet.writer import PartitionWriter
from blinkcan.protocol import Frame
from blinkcan.protocol.cob import HEARTBEAT
from blinkcan.protocol.j1939 import PGN_PROPRIETARY_A, compose_id


def _rows(frames: list[Frame]) -> list[list[Detail]]:
    keypad, keybox = describe_device("keypad"), describe_device("keybox")
    decoder = Decoder({keypad.default_node_id: keypad, keybox.default_node_id: keybox})
    rows = EventRows(decoder)
    return [rows.rows(decoder.decode(frame, 1.0)).details for frame in frames]


def test_led_rows_say_which_keys_changed_colour() -> None:
    keypad = describe_device("keypad")
    layout, node = keypad.pdo("led_on"), keypad.default_node_id
    red_1_3 = Frame(layout.cob_id(node), layout.encode({"red": 0b101, "green": 0b001, "blue": 0}))
    red_3 = Frame(layout.cob_id(node), layout.encode({"red": 0b100, "green": 0, "blue": 0}))
    boot = Frame(HEARTBEAT + node, b"\x00")
    assert _rows([red_1_3, red_1_3, red_3, boot, red_3]) == [
        [Detail("led", key=1, state="on", colour="yellow"),
         Detail("led", key=3, state="on", colour="red")],
        [Detail("led", state="unchanged")],
        [Detail("led", key=1, state="on", colour="off")],
        [Detail("heartbeat", state="boot-up")],
        [Detail("led", key=3, state="on", colour="red")],  # dark again after the boot-up
    ]


def test_output_and_fault_rows_say_which_pins_changed() -> None:
    keybox = describe_device("keybox")
    outputs, faults, node = keybox.pdo("outputs"), keybox.pdo("faults"), keybox.default_node_id
    high_4 = Frame(outputs.cob_id(node), outputs.encode({"off": 0, "high": 0b1000}))
    off_wins = Frame(outputs.cob_id(node), outputs.encode({"off": 0b1000, "high": 0b1000}))
    fault_4 = Frame(faults.cob_id(node), faults.encode({"faults": 0b1000}))
    none = Frame(faults.cob_id(node), faults.encode({"faults": 0}))
    assert _rows([high_4, high_4, off_wins, fault_4, fault_4, none]) == [
        [Detail("output", pin=4, state="high")],
        [Detail("output", state="unchanged")],
        [Detail("output", pin=4, state="off")],  # KBX §17: OFF wins
        [Detail("fault", pin=4, state="fault")],
        [Detail("fault", state="unchanged", value=1)],  # the periodic message (KBX §25)
        [Detail("fault", pin=4, state="cleared")],
    ]


@pytest.mark.parametrize(("seconds", "expected"), [
    (1_780_271_999.999999, (1_780_271_999_999_999, "2026-05-31")),
    (1_780_272_000.0, (1_780_272_000_000_000, "2026-06-01")),
    (-1.0, (-1_000_000, "1969-12-31")),
    (math.nan, (None, "unknown")),
    (math.inf, (None, "unknown")),
    (1e12, (None, "unknown")),  # after year 9999
])
def test_times_and_their_dates(seconds: float, expected: tuple[int | None, str]) -> None:
    writer = PartitionWriter(MemoryFileSystem(), "/x", "x.parquet", "source")
    writer.time_and_date(1_780_271_000.0)  # a day seen before: the fast path
    assert writer.time_and_date(seconds) == expected


@settings(max_examples=80, deadline=None)
@given(st.lists(st.one_of(
    st.floats(1_780_271_000.0, 1_780_272_999.0),  # around a midnight: one date or two
    st.floats(-1e12, 1e12), st.sampled_from([math.nan, math.inf, -math.inf]),
    st.floats(86_399.999_999, 86_400.000_001)), min_size=1, max_size=40))
def test_times_of_a_row_group_are_each_times_own(seconds: list[float]) -> None:
    """The writer's times of many rows (Arrow's arithmetic where they are of one day) are
    what each time gives alone."""
    writer = PartitionWriter(MemoryFileSystem(), "/x", "x.parquet", "source")
    one = PartitionWriter(MemoryFileSystem(), "/x", "x.parquet", "source")
    micros, dates = writer.times_and_dates(seconds)
    expected = [one.time_and_date(s) for s in seconds]
    as_ints = micros.cast(pa.int64()).to_pylist()
    assert as_ints == [e[0] for e in expected]
    assert ([dates] * len(seconds) if isinstance(dates, str) else dates) == \
        [e[1] for e in expected]


def test_times_of_one_day_take_arrows_way() -> None:
    writer = PartitionWriter(MemoryFileSystem(), "/x", "x.parquet", "source")
    seconds = [1_780_271_940.0000005, 1_780_271_940.0000015, 1_780_271_999.9999995]
    micros, dates = writer.times_and_dates(seconds)
    assert dates == "2026-05-31"  # one date for them all: the vectorised way
    assert micros.cast(pa.int64()).to_pylist() == [round(s * 1_000_000) for s in seconds]


@pytest.mark.parametrize(("state", "word"), [
    (LedState.OFF, "off"), (LedState.ON, "on"), (LedState.BLINK, "blink"),
    (LedState.ALTERNATE, "alternate")])
def test_a_j1939_single_led_command_is_an_led_row(state: LedState, word: str) -> None:
    """PKP-2600-SI J1939 §7a: the key, the state (byte 5) as a word, the colour's name."""
    single_led = next(c for c in COMMANDS if c.name == "single_led")
    command = Frame(compose_id(PGN_PROPRIETARY_A, DEFAULT_HOST_ADDRESS, DEFAULT_ADDRESS,
                               PRIORITY), single_led.encode(5, 1, state, 2), extended=True)
    decoder = Decoder()
    assert EventRows(decoder).rows(decoder.decode(command, 1.0)).details == [
        Detail("led", key=5, state=word, colour=COLOUR_CODES[1])]
