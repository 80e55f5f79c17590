"""A candump line that is no frame never costs the frames around it (issue 23): bytes that
are not UTF-8, comments, blank lines, a compressed log's lines; decode shows it in its
place, convert names it and exits 1, and the readers' lines stay bounded whatever the file."""

from __future__ import annotations

import gzip
import json
import subprocess
import sys
import tracemalloc
from pathlib import Path

import pytest
from click.testing import CliRunner

from blinkcan.cli.main import cli
from blinkcan.fleet.sources import read_columns
from blinkcan.formats.log_source import MAX_LINE
from blinkcan.formats.logs import read_log, read_messages
from blinkcan.formats.unreadable import UnreadableLine
from blinkcan.protocol import Frame

GOOD = 3000  # over one 64 KiB read chunk of lines


def _lines(count: int, start: int = 0) -> list[bytes]:
    return [f"({1700000000 + n / 1000:.6f}) can0 195#{n % 256:02X}00\n".encode()
            for n in range(start, start + count)]


def _items(path: Path) -> dict[str, list[object]]:
    """What each reader reads of ``path``: frames as their times, a line as its record."""
    def entry(time: float, item: object) -> object:
        return item if isinstance(item, UnreadableLine) else round(time, 6)

    return {
        "read_log": [entry(t, item) for t, item in read_log(path)],
        "read_messages": [entry(getattr(m, "timestamp", 0.0), m)
                          for m in read_messages(path, unreadable=True)],
        "read_columns": [entry(t, block.others.get(row)) for block in read_columns(path)
                         for row, t in enumerate(block.times)],
    }


def test_a_byte_that_is_not_utf8_costs_its_line_only(tmp_path: Path) -> None:
    # the whole 64 KiB block around it was lost: the text decoder raised for the block
    lines = _lines(GOOD)
    bad = b"(1700000001.500000) can\xff0 195#00\n"
    log = tmp_path / "bytes.log"
    log.write_bytes(b"".join(lines[:100]) + bad + b"".join(lines[100:]))
    times = [round(1700000000 + n / 1000, 6) for n in range(GOOD)]
    for reader, items in _items(log).items():
        line = items.pop(100)
        assert items == times, reader
        assert isinstance(line, UnreadableLine), reader
        assert (line.number, line.text, line.time) == (101, r"(1700000001.500000) can\xff0 195#00",
                                                       1700000001.5)
        assert str(line) == r"line 101: '(1700000001.500000) can\xff0 195#00' is not UTF-8 text"


def test_decode_json_keeps_the_line_in_its_place_and_names_it(tmp_path: Path) -> None:
    log = tmp_path / "bytes.log"
    log.write_bytes(b"(1.000000) can0 715#05\n\xfe\xff garbage\n(2.000000) can0 715#05\n")
    result = subprocess.run([sys.executable, "-m", "blinkcan", "decode", "--json", str(log)],
                            capture_output=True, text=True, check=False)
    assert result.returncode == 0, result.stderr
    objects = [json.loads(line) for line in result.stdout.splitlines()]
    assert [o["kind"] for o in objects] == ["heartbeat", "unreadable", "heartbeat"]
    assert objects[1] == {"time": None, "kind": "unreadable", "line": 2,
                          "text": r"\xfe\xff garbage",
                          "error": r"line 2: '\xfe\xff garbage' is not UTF-8 text"}
    assert f"{log}: line 2: " in result.stderr
    assert f"{log}: 1 line could not be read (line 2): in the output as 'unreadable', in " \
           "place; the 2 frames around it were read" in result.stderr


def test_standard_input_with_a_byte_that_is_not_utf8(tmp_path: Path) -> None:
    text = b"(1.000000) can0 715#05\n(1.5) \xff\n(2.000000) can0 715#05\n"
    result = subprocess.run([sys.executable, "-m", "blinkcan", "decode", "--json", "-"],
                            input=text, capture_output=True, check=False)
    assert result.returncode == 0, result.stderr
    assert [json.loads(line)["kind"] for line in result.stdout.splitlines()] == [
        "heartbeat", "unreadable", "heartbeat"]


def test_comments_and_blank_lines_are_skipped(tmp_path: Path) -> None:
    log = tmp_path / "commented.log"
    log.write_text("# candump -L can0, recorded on the boat\n\n(1.000000) can0 715#05\n"
                   "   # an indented comment: a b c\n  \t\n# (2.0) can0 715#05\n"
                   "(3.000000) can0 715#05\n#\n")
    for reader, items in _items(log).items():
        assert items == [1.0, 3.0], reader
    result = CliRunner().invoke(cli, ["convert", str(log), str(tmp_path / "out.pcap")])
    assert result.exit_code == 0, result.output
    assert "2 frames written" in result.output


def test_convert_keeps_the_frames_after_a_bad_line_names_it_and_exits_1(
        tmp_path: Path) -> None:
    log = tmp_path / "bad.log"
    lines = _lines(10)
    log.write_bytes(b"".join(lines[:3]) + b"garbage\n" + b"".join(lines[3:])
                    + b"(1.0) can0 1X\n")
    result = CliRunner().invoke(cli, ["convert", str(log), str(tmp_path / "out.log")])
    assert result.exit_code == 1, result.output
    assert "10 frames written" in result.output
    assert f"{log}: line 4: 'garbage' is not a whole candump line" in result.output
    assert f"{log}: line 12: '(1.0) can0 1X' is not a whole candump line" in result.output
    assert f"Error: {log}: 2 lines could not be read (lines 4, 12): not in " \
           f"{tmp_path / 'out.log'}, which holds frames only; the 10 frames around them were " \
           "read" in result.output
    assert (tmp_path / "out.log").read_bytes() == b"".join(
        line.replace(b"\n", b" R\n") for line in lines)


def test_a_file_none_of_whose_lines_is_a_frame_cannot_be_read(tmp_path: Path) -> None:
    log = tmp_path / "all-bad.log"
    log.write_text("garbage\nmore garbage\n")
    for command in (["decode", str(log)], ["convert", str(log), str(tmp_path / "o.pcap")]):
        result = CliRunner().invoke(cli, command)
        assert result.exit_code == 1
        assert f"Error: {log}: not a readable log (no line is a candump frame (line 1: " \
               "'garbage' is not a whole candump line" in result.output
    assert not (tmp_path / "o.pcap").exists()


def test_a_gz_log_read_through_python_can_bounds_its_lines(tmp_path: Path) -> None:
    # python-can's LogReader opened .gz logs and read their lines whole: one 24 MB line (a
    # few KiB compressed) was held in memory at once
    # (a line over MAX_LINE after the first is one unreadable line, its prefix kept)
    log = tmp_path / "huge.log.gz"
    log.write_bytes(gzip.compress(b"(1.0) can0 715#05\n" + b"0" * (24 << 20)))
    for reader in (lambda: [item for _, item in read_log(log)],
                   lambda: list(read_messages(log, unreadable=True))):
        tracemalloc.start()
        try:
            items = reader()
            peak = tracemalloc.get_traced_memory()[1]
        finally:
            tracemalloc.stop()
        assert peak < 4 << 20, f"{peak:,} bytes to read past a 24 MB line"
        assert len(items) == 2
        assert isinstance(items[-1], UnreadableLine)
        assert items[-1].number == 2
        assert items[-1].text == "0" * MAX_LINE


def test_a_gz_candump_log_decodes_as_the_plain_one(tmp_path: Path) -> None:
    plain = tmp_path / "t.log"
    plain.write_text("(1.000000) can0 715#05\ngarbage\n(2.000000) can0 70C#R\n")
    packed = tmp_path / "t.log.gz"
    packed.write_bytes(gzip.compress(plain.read_bytes()))
    assert [str(i) for _, i in read_log(packed)] == [str(i) for _, i in read_log(plain)]
    assert [type(i) for _, i in read_log(packed)] == [Frame, UnreadableLine, type(
        next(m for m in read_messages(plain)))]


@pytest.mark.parametrize(("last", "frames"), [
    ("(1.2) can0 12", 2),                 # cut inside the identifier: it read as frame 012#
    ("(1.2) can0 123#0102030", 2),        # cut inside the data: python-can read 01 02 03
    ("(1.2) can0 123##", 2),              # cut after a CAN FD mark
    ("(1.2", 2),                          # cut inside the time
    ("", 3),                              # an empty last line: nothing cut
])
@pytest.mark.parametrize("ending", ["\n", "\r\n"])
def test_a_capture_cut_anywhere_keeps_its_frames_and_names_the_cut(
        tmp_path: Path, last: str, frames: int, ending: str) -> None:
    log = tmp_path / "cut.log"
    whole = ["(1.000000) can0 123#01", "(1.100000) can0 123#02"] + (
        ["(1.150000) can0 123#03", ""] if not last else [last])
    log.write_bytes(ending.join(whole).encode())
    for reader, items in _items(log).items():
        unreadable = [item for item in items if isinstance(item, UnreadableLine)]
        assert len(items) - len(unreadable) == frames, reader
        if last:
            [line] = unreadable
            assert (line.number, line.text, line.cut_off) == (3, last, True), reader
            assert str(line).endswith(": the capture ends there, cut off")
        else:
            assert not unreadable, reader
