"""A candump log with a bad line: every frame before it comes out, in order, and the error
names the file and the line, wherever the line falls (a block's first line, its middle, its
last, across the read chunk's boundary), for decode (the fast reader), convert (python-can's
reader) and the fleet (columns)."""

from __future__ import annotations

from pathlib import Path

import pytest

from blinkcan.fleet.sources import read_columns
from blinkcan.formats.log_source import MAX_LINE
from blinkcan.formats.logs import LogError, read_log, read_messages

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


@pytest.mark.parametrize("where", ["first", "middle", "boundary", "last"])
@pytest.mark.parametrize("bad", ["(1700000001.5) can0 1X5#00", "garbage", "x" * (MAX_LINE + 1)])
def test_the_frames_before_a_bad_line_come_out_and_the_line_is_named(
        tmp_path: Path, where: str, bad: str) -> None:
    lines = _lines(GOOD)
    at = {"first": 0, "middle": GOOD // 2, "boundary": _chunk_boundary(lines),
          "last": GOOD}[where]
    log = tmp_path / "bad.log"
    log.write_text("".join(lines[:at]) + bad + "\n" + "".join(lines[at:]))
    expected = [float(line[1:18]) for line in lines[:at]]

    times: list[float] = []
    with pytest.raises(LogError, match=rf"bad\.log: .*line {at + 1}\b"):
        times.extend(time for time, _ in read_log(log))
    assert times == expected

    times = []
    with pytest.raises(LogError, match=rf"bad\.log: .*line {at + 1}\b"):
        times.extend(message.timestamp for message in read_messages(log))
    assert times == expected

    times = []
    with pytest.raises(ValueError, match=rf"line {at + 1}\b"):
        times.extend(time for block in read_columns(log) for time in block.times)
    assert times == expected


def test_a_capture_cut_off_mid_line_is_named_plainly_and_convert_keeps_its_frames(
        tmp_path: Path) -> None:
    # a killed candump leaves its last line half written: the message says so in the
    # user's words (not python-can's "not enough values to unpack"), and convert keeps every
    # frame before it (it wrote nothing; found by the newcomer pass)
    from click.testing import CliRunner

    from blinkcan.cli.main import cli
    from blinkcan.protocol import Frame

    log = tmp_path / "cut.log"
    log.write_text("(1.000000) can0 18A#0000000001\n(1.100000) can0 18A#0000000000\n(1.2000")
    for command in (["decode", str(log)], ["convert", str(log), str(tmp_path / "cut.asc")]):
        result = CliRunner().invoke(cli, command)
        assert result.exit_code == 1, result.output
        assert "line 3: '(1.2000' is not a whole candump line" in result.output
        assert "unpack" not in result.output
    assert [frame for _, frame in read_log(tmp_path / "cut.asc")] == [
        Frame(0x18A, bytes([0, 0, 0, 0, 1])), Frame(0x18A, bytes(5))]
