"""A capture whose logger was killed mid-write ends in half a line; a capture may hold a bad
line anywhere (a corrupt byte, two writers interleaved). Its frames are the fleet's data: the
file is decoded, every frame around the line is in the dataset, the line is an ``unreadable``
row with its text and line number, and the result and ``decode --parquet`` name it. A file
none of whose lines is a frame fails, named (issue 23)."""

from __future__ import annotations

import gzip
from pathlib import Path

import pytest
from click.testing import CliRunner

from blinkcan.cli.main import cli
from blinkcan.fleet import decode_files
from blinkcan.fleet.query import connect

LINES = "(1.000000) can0 18A#0000000001\n(1.100000) can0 18A#0000000000\n"
CUT = "line 3: '(1.2000' is not a whole candump line ((TIME) CHANNEL ID#DATA): the capture " \
      "ends there, cut off"


def _rows(lake: Path) -> list[tuple[object, ...]]:
    with connect(str(lake)) as connection:
        return connection.execute(
            "SELECT kind, value, text, can_id, data, epoch(time) FROM events "
            "ORDER BY value NULLS FIRST, time").fetchall()


@pytest.mark.parametrize("suffix", [".log", ".log.gz"])
def test_a_capture_cut_off_mid_line_is_decoded_and_the_cut_line_kept(tmp_path: Path,
                                                                     suffix: str) -> None:
    log = tmp_path / f"unit{suffix}"
    text = (LINES + "(1.2000").encode()
    log.write_bytes(gzip.compress(text) if suffix.endswith(".gz") else text)
    [result] = decode_files([log], str(tmp_path / "lake"))
    assert (result.status, result.frames, result.unreadable) == ("decoded", 2, 1)
    assert result.cut_off == CUT
    assert result.unreadable_lines == (CUT,)
    rows = _rows(tmp_path / "lake")
    assert [row[0] for row in rows] == ["undecoded", "undecoded", "unreadable"]
    assert rows[2][1:5] == (3, "(1.2000", None, None)
    shown = CliRunner().invoke(cli, ["decode", str(log), "--parquet", str(tmp_path / "l2")])
    assert shown.exit_code == 0, shown.output
    assert f"{log}: {CUT}" in shown.output
    assert "1 line could not be read (named above): kept as 'unreadable' row with its text; " \
           "its 2 frames are in the dataset" in shown.output


def test_a_bad_line_inside_a_capture_is_a_row_and_the_frames_after_it_are_decoded(
        tmp_path: Path) -> None:
    log = tmp_path / "unit.log"
    log.write_text("(1.000000) can0 18A#0000000001\n(1.200000) can0 18A#00000\n"
                   "(1.300000) can0 18A#00\n")
    [result] = decode_files([log], str(tmp_path / "lake"))
    assert (result.status, result.frames, result.unreadable, result.cut_off) == (
        "decoded", 2, 1, None)
    [named] = result.unreadable_lines
    assert named.startswith("line 2: '(1.200000) can0 18A#00000' is not a candump line")
    rows = _rows(tmp_path / "lake")
    # the line's own time places it (its date partition too)
    assert rows[2] == ("unreadable", 2, "(1.200000) can0 18A#00000", None, None, 1.2)
    # a file decoded again is skipped, and says its unreadable lines again
    [again] = decode_files([log], str(tmp_path / "lake"))
    assert (again.status, again.unreadable, again.unreadable_lines) == (
        "skipped", 1, result.unreadable_lines)


@pytest.mark.parametrize("text", ["(1.2000", "garbage\n(1.0) can0 1X5#00\n", "\xff\xfe\n"])
def test_a_file_none_of_whose_lines_is_a_frame_fails_named(tmp_path: Path, text: str) -> None:
    log = tmp_path / "unit.log"
    log.write_bytes(text.encode("latin-1"))
    [result] = decode_files([log], str(tmp_path / "lake"))
    assert result.status == "failed"
    assert "no line is a candump frame (line 1: " in (result.error or "")
    assert not list((tmp_path / "lake").glob("model=*"))


def test_a_whole_last_line_without_a_newline_is_a_frame(tmp_path: Path) -> None:
    log = tmp_path / "unit.log"
    log.write_text(LINES + "(1.200000) can0 18A#0000000001")
    [result] = decode_files([log], str(tmp_path / "lake"))
    assert (result.status, result.frames, result.cut_off, result.unreadable) == (
        "decoded", 3, None, 0)
