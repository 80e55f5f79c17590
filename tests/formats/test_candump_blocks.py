"""The candump block reader (formats/candump_blocks.py) reads what the line reader reads.

Logs mix plain data-frame lines with every odd kind of line; read with small blocks (so block
boundaries fall anywhere, odd lines included), both readers give the same frames, the same
unreadable lines (numbers, texts, reasons) and the same messages, or the same error.
"""

from __future__ import annotations

import io

import can
from hypothesis import given, settings
from hypothesis import strategies as st

from blinkcan.formats.candump import read_candump_columns
from blinkcan.formats.candump_blocks import PlainBlocks
from blinkcan.formats.log_source import MAX_LINE

_plain = st.builds(
    lambda time, channel, ident, data, upper: (
        f"({time}) {channel} {ident}#{data.hex().upper() if upper else data.hex()}"),
    st.one_of(st.floats(0, 2e9).map(lambda t: f"{t:.6f}"),
              st.floats(0, 1e6).map(repr).filter(lambda t: "e" not in t),
              st.sampled_from(["1700000000.000500", "0.5", "12.0"])),
    st.sampled_from(["can0", "vcan1", "can.1", "slcan0", "x"]),
    st.one_of(st.integers(0, 0x7FF).map(lambda i: f"{i:03X}"),
              st.integers(0, 0x7FF).map(lambda i: f"{i:03x}"),
              st.integers(0, 0x1FFFFFFF).map(lambda i: f"{i:08X}")),
    st.binary(max_size=8), st.booleans())

#: lines the block reader must leave to the line reader, or read as the line reader does
_ODD = [
    "", "   ", "# a comment", "#", "(1.000000) can0 715#R", "(1.000000) can0 715#R2",
    "(1.000000) can0 715##1AABB", "(1.000000) can0 20000004#0000000000000000",
    "(1.000000) can0 12345#00", "(1.000000) can0 1234567#00", "(1.000000) can0 000000001#00",
    "(1.000000) can0 FFF#00", "(1.000000) can0 800#00", "(1.000000) can0 3FFFFFFF#00",
    "(1.000000) can0 715#123", "(1.000000) can0 715#000102030405060708",
    "(1a.5) can0 715#00", "(.5) can0 715#00", "(1.) can0 715#00", "(1.5e3) can0 715#00",
    "(" + "9" * 400 + ".0) can0 715#00", "(nan) can0 715#00", "(inf) can0 715#00",
    "(1.000000) 0 715#00", "(1.000000) a 715#00", "(1.000000)  715#00", "(1.000000) can0  715#00",
    "(1.000000) can0 715#00 ", " (1.000000) can0 715#00", "(1.000000)\tcan0 715#00",
    "(1.000000) can0 715#00 R", "(1.000000) can0 715#00 T", "(1.000000) can0 715#00 X",
    "(1.000000)can0 715#00", "1.000000 can0 715#00", "(1.000000) can0 715", "(1.000000) can0",
    "(1.000000) c#n 715#00", "(1.000000) c(n 715#00", "(1.000000) c)n 715#00",
    "(1.000000) can0 #00", "(1.000000) can0 715#", "(1.000000) can0 715#00\r",
    "(1.000000) cän0 715#00", "(1.000000) can0 715#0\udc80", "(1.0.0) can0 715#00",
    "(1.000000) can0 715#00#00", "(1.000000) can0 7_15#00", "(1_0.5) can0 715#00",
    "(1.000000) can0 715#" + "0" * (MAX_LINE + 10),
]
#: lines that are not plain data frames: never read whole
_NOT_FRAMES = [
    "", "# a comment", "(1.000000) can0 715#R", "(1.000000) can0 715##1AABB",
    "(1.000000) can0 20000004#0000000000000000", "(1.000000) can0 FFF#00",
    "(1.000000) can0 715#123", "(1.000000) can0 715#000102030405060708", "(nan) can0 715#00",
    "(" + "9" * 400 + ".0) can0 715#00", "(1.000000) can0 715#00\r", "(1.000000) can0 715",
    "(1.000000)  715#00", "(1a.5) can0 715#00", "(1.000000) can0 000000001#00",
]
_line = st.one_of(_plain, _plain, _plain, st.sampled_from(_ODD),
                  _plain.map(lambda line: line + "\r"))


def _read(text: str, fast: PlainBlocks | None, chunk: int) -> list[object] | str:
    """Every row of the log as a comparable tuple, or the error reading it raised."""
    rows: list[object] = []
    try:
        for block in read_candump_columns(io.StringIO(text), fast, chunk):
            for row, columns in enumerate(zip(block.times, block.channels, block.ids,
                                              block.extended, block.data, strict=True)):
                other: object = block.others.get(row)
                if isinstance(other, can.Message):
                    other = (other.timestamp, other.arbitration_id, other.is_extended_id,
                             other.is_remote_frame, other.is_error_frame, other.is_fd,
                             other.dlc, bytes(other.data), other.channel)
                rows.append((repr(columns), other))
    except ValueError as error:
        rows.append(f"ValueError: {error}")
    return rows


@settings(max_examples=150, deadline=None)
@given(st.lists(_line, max_size=40), st.booleans(), st.integers(60, 600))
def test_blocks_read_what_lines_read(lines: list[str], newline_at_end: bool, chunk: int
                                     ) -> None:
    text = "\n".join(lines) + ("\n" if newline_at_end and lines else "")
    assert _read(text, PlainBlocks(), chunk) == _read(text, None, chunk)


def test_a_block_of_plain_lines_is_read_whole_and_any_other_line_is_left_to_the_lines() -> None:
    plain = ["(1700000000.000500) can0 715#05", "(1700000000.001000) vcan1 18FEF100#0102",
             "(1700000000.002000) can0 00C#"]
    block = PlainBlocks()(plain)
    assert block is not None
    assert (block.times, block.channels, block.ids, block.extended, block.data) == (
        [1700000000.0005, 1700000000.001, 1700000000.002], ["can0", "vcan1", "can0"],
        [0x715, 0x18FEF100, 0x00C], [False, True, False], [b"\x05", b"\x01\x02", b""])
    for odd in _ODD:  # whatever is read whole is what the lines give
        if "\udc80" not in odd and odd.isascii():
            lines = [*plain, odd]
            whole = PlainBlocks()(lines)
            by_lines = list(read_candump_columns(io.StringIO("\n".join(lines) + "\n")))
            assert whole is None or [whole] == by_lines, odd
    for odd in _NOT_FRAMES:
        assert PlainBlocks()([*plain, odd]) is None, odd


@settings(max_examples=40, deadline=None)
@given(st.lists(_plain, min_size=1, max_size=40))
def test_plain_lines_never_fall_back(lines: list[str]) -> None:
    """The fast path is taken for plain lines, whatever their identifiers, data and times."""
    assert PlainBlocks()(lines) is not None
