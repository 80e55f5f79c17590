"""The fast candump reader gives what python-can's own reader gives, line for line."""

from __future__ import annotations

import io
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import can
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from blinkcan.formats.candump import read_candump, with_error_details
from blinkcan.formats.logs import read_frames, read_log
from blinkcan.formats.unreadable import UnreadableLine
from blinkcan.protocol import Frame


def _as_tuple(message: can.Message) -> tuple[object, ...]:
    return (round(message.timestamp, 6), message.arbitration_id, message.is_extended_id,
            message.is_remote_frame, message.is_error_frame, message.is_fd, message.dlc,
            bytes(message.data))


def _ours(text: str) -> list[tuple[object, ...]]:
    found: list[tuple[object, ...]] = []
    for timestamp, item in read_candump(io.StringIO(text)):
        assert not isinstance(item, UnreadableLine), item
        if isinstance(item, Frame):
            found.append((round(timestamp, 6), item.can_id, item.extended, False, False, False,
                          len(item.data), item.data))
        else:
            found.append(_as_tuple(item))
    return found


def _python_cans(path: Path) -> list[tuple[object, ...]]:
    """python-can's reader, error frames completed from their lines (restore_error_details)."""
    with can.LogReader(str(path)) as reader, path.open() as lines:
        return [_as_tuple(message) for message in with_error_details(iter(reader), lines)]


_line = st.one_of(
    st.builds(lambda i, d: f"{i:03X}#{d.hex().upper()}", st.integers(0, 0x7FF),
              st.binary(max_size=8)),
    st.builds(lambda i, d: f"{i:08X}#{d.hex()}", st.integers(0, 0x1FFFFFFF),
              st.binary(max_size=8)),
    st.builds(lambda i: f"{i:03X}#R", st.integers(0, 0x7FF)),
    st.builds(lambda i, n: f"{i:03X}#R{n}", st.integers(0, 0x7FF), st.integers(0, 8)),
    st.builds(lambda c, d: f"{0x20000000 | c:08X}#{d.hex()}", st.integers(0, 0x1FF),
              st.binary(min_size=8, max_size=8)),
    st.builds(lambda i, d: f"{i:03X}##1{d.hex()}", st.integers(0, 0x7FF),
              st.sampled_from([b"", bytes(12), bytes(range(64))])),
)


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(st.floats(0, 2e9, allow_nan=False), st.sampled_from(["can0", "vcan1"]),
                          _line, st.sampled_from(["", " R", " T"])), max_size=20))
def test_round_trip_against_python_cans_reader(lines: list[tuple[float, str, str, str]]
                                                ) -> None:
    text = "".join(f"({t:.6f}) {channel} {frame}{suffix}\n" for t, channel, frame, suffix in lines)
    handle, name = tempfile.mkstemp(suffix=".log")
    os.close(handle)
    path = Path(name)
    try:
        path.write_text(text)
        assert _ours(text) == _python_cans(path)
    finally:
        path.unlink(missing_ok=True)


def test_blank_lines_are_skipped_as_python_can_does(tmp_path: Path) -> None:
    path = tmp_path / "blank.log"
    path.write_text("\n(1.0) can0 715#05\n   \n(2.0) can0 70C#R\n")
    assert _ours(path.read_text()) == _python_cans(path)
    assert [f for _, f in read_frames(path)] == [Frame(0x715, b"\x05")]
    assert [type(item).__name__ for _, item in read_log(path)] == ["Frame", "Message"]


@pytest.mark.parametrize("line", [
    "(nan) can0 715#00",              # the fast path: a classic data frame
    "(inf) can0 715#R",               # python-can's path: a remote frame
    "(-inf) can0 12345678##1AABB",    # python-can's path: a CAN FD frame
])
def test_a_time_that_is_not_a_finite_number_is_an_unreadable_line(line: str) -> None:
    log = io.StringIO(f"(1.000000) can0 715#00\n{line}\n(2.000000) can0 715#05\n")
    items = list(read_candump(log))
    assert [item for _, item in items[::2]] == [Frame(0x715, b"\x00"), Frame(0x715, b"\x05")]
    unreadable = items[1][1]
    assert isinstance(unreadable, UnreadableLine)
    assert (unreadable.number, unreadable.text, unreadable.time) == (2, line, None)
    assert "is not a finite number of seconds" in unreadable.reason


def test_decode_names_the_file_and_line_of_a_non_finite_time(tmp_path: Path) -> None:
    log = tmp_path / "n.log"
    log.write_text("(1.000000) can0 715#00\n(nan) can0 715#00\n(2.000000) can0 715#05\n")
    result = subprocess.run([sys.executable, "-m", "blinkcan", "decode", str(log)],
                            capture_output=True, text=True, check=False)
    assert result.returncode == 0, result.stderr
    assert len(result.stdout.splitlines()) == 3
    assert f"{log}: line 2: '(nan) can0 715#00' is not a candump line (time (nan) is not a " \
        "finite number of seconds)" in result.stderr


def test_an_identifier_over_8_hex_digits_is_refused_not_read_as_an_error_frame() -> None:
    log = io.StringIO("(1.000000) can0 7FFFFFFFFFF#00\n")
    with pytest.raises(ValueError, match="7FFFFFFFFFF has more than 8 hex digits"):
        list(read_candump(log))
