"""A candump log with a bad line: every frame before it and after it comes out, in order, and
the line is named (its number, its text) in its place, wherever it falls (a block's first
line, its middle, its last, across the read chunk's boundary), for decode (the fast reader),
convert (python-can's reader) and the fleet (columns). A first line over MAX_LINE ends the
reading (not a candump log: a binary file, /dev/zero); a later one is unreadable (issue 23)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from blinkcan.fleet.sources import read_columns
from blinkcan.formats.log_source import MAX_LINE
from blinkcan.formats.logs import LogError, read_log, read_messages
from blinkcan.formats.unreadable import UnreadableLine

GOOD = 3000  # over one 64 KiB read chunk of lines


def _lines(count: int) -> list[str]:
    return [f"({1700000000 + n / 1000:.6f}) can0 195#{n % 256:02X}00\n" for n in range(count)]


def _chunk_boundary(lines: list[str]) -> int:
    """The index of the line that starts before the 64 KiB read boundary and ends after."""
    size = 0
    for index, line in enumerate(lines):
        if size + len(line) > 1 << 16:
            return index
        size += len(line)
    raise AssertionError("too few lines")


def _log(tmp_path: Path, where: str, bad: str) -> tuple[Path, int, list[float]]:
    """A log of GOOD frames with ``bad`` at ``where``: its path, the bad line's number, the
    frames' times."""
    lines = _lines(GOOD)
    at = {"first": 0, "middle": GOOD // 2, "boundary": _chunk_boundary(lines),
          "last": GOOD}[where]
    log = tmp_path / "bad.log"
    log.write_text("".join(lines[:at]) + bad + "\n" + "".join(lines[at:]))
    return log, at + 1, [float(line[1:18]) for line in lines]


WHERE = ["first", "middle", "boundary", "last"]


@pytest.mark.parametrize("where", WHERE)
@pytest.mark.parametrize("bad", ["(1700000001.5) can0 1X5#00", "garbage"])
def test_every_frame_around_a_bad_line_comes_out_and_the_line_is_named_in_its_place(
        tmp_path: Path, where: str, bad: str) -> None:
    log, number, times = _log(tmp_path, where, bad)
    before = number - 1

    def check(items: list[tuple[float, object]]) -> None:
        assert [time for time, item in items if not isinstance(item, UnreadableLine)] == times
        [(position, line)] = [(n, item) for n, (_, item) in enumerate(items)
                              if isinstance(item, UnreadableLine)]
        assert position == before
        assert isinstance(line, UnreadableLine)
        assert (line.number, line.text) == (number, bad)
        assert str(line).startswith(f"line {number}: '{bad}' is not a")

    check(list(read_log(log)))
    check([(getattr(m, "timestamp", 0.0), m) for m in read_messages(log, unreadable=True)])
    check([(time, block.others.get(row)) for block in read_columns(log)
           for row, time in enumerate(block.times)])
    with pytest.raises(LogError, match=rf"bad\.log: line {number}: '{re.escape(bad)}'"):
        list(read_messages(log))  # the strict reader: named, not skipped unsaid


def test_a_first_line_over_max_line_ends_the_reading(tmp_path: Path) -> None:
    # a later one is an unreadable line and reading goes on (tests/formats/test_read_on.py)
    log, number, times = _log(tmp_path, "first", "x" * (MAX_LINE + 1))
    expected = times[:number - 1]

    read: list[float] = []
    with pytest.raises(LogError, match=rf"bad\.log: .*line {number}\b"):
        read.extend(time for time, _ in read_log(log))
    assert read == expected

    read = []
    with pytest.raises(LogError, match=rf"bad\.log: .*line {number}\b"):
        read.extend(message.timestamp for message in read_messages(log))
    assert read == expected

    read = []
    with pytest.raises(ValueError, match=rf"line {number}\b"):
        read.extend(time for block in read_columns(log) for time in block.times)
    assert read == expected


def test_a_capture_cut_off_mid_line_is_named_plainly_and_convert_keeps_its_frames(
        tmp_path: Path) -> None:
    # a killed candump leaves its last line half written: the message says so in the
    # user's words (not python-can's "not enough values to unpack"), decode shows it in its
    # place, and convert keeps every frame before it and says the line is not in the target
    from click.testing import CliRunner

    from blinkcan.cli.main import cli
    from blinkcan.protocol import Frame

    log = tmp_path / "cut.log"
    log.write_text("(1.000000) can0 18A#0000000001\n(1.100000) can0 18A#0000000000\n(1.2000")
    cut = "line 3: '(1.2000' is not a whole candump line ((TIME) CHANNEL ID#DATA): the " \
          "capture ends there, cut off"
    for command, status in ((["decode", str(log)], 0),
                            (["convert", str(log), str(tmp_path / "cut.asc")], 1)):
        result = CliRunner().invoke(cli, command)
        assert result.exit_code == status, result.output
        assert f"{log}: {cut}" in result.output
        assert "unpack" not in result.output
    assert "1 line could not be read (line 3): not in" in result.output
    assert [frame for _, frame in read_log(tmp_path / "cut.asc")] == [
        Frame(0x18A, bytes([0, 0, 0, 0, 1])), Frame(0x18A, bytes(5))]
