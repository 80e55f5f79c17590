"""A capture whose logger was killed mid-write ends in half a line. Its frames are the
fleet's data: the file is decoded, every frame before the cut is in the dataset and the cut
line is named (the whole file was "failed" and none of its rows kept). A bad line inside a
file still fails that file, named."""

from __future__ import annotations

import gzip
from pathlib import Path

import pytest
from click.testing import CliRunner

from blinkcan.cli.main import cli
from blinkcan.fleet import decode_files
from blinkcan.fleet.query import connect

LINES = "(1.000000) can0 18A#0000000001\n(1.100000) can0 18A#0000000000\n"


@pytest.mark.parametrize("suffix", [".log", ".log.gz"])
def test_a_capture_cut_off_mid_line_is_decoded_up_to_the_cut(tmp_path: Path,
                                                               suffix: str) -> None:
    log = tmp_path / f"unit{suffix}"
    text = (LINES + "(1.2000").encode()
    log.write_bytes(gzip.compress(text) if suffix.endswith(".gz") else text)
    [result] = decode_files([log], str(tmp_path / "lake"))
    assert (result.status, result.frames) == ("decoded", 2)
    assert result.cut_off is not None
    assert result.cut_off.startswith("line 3: '(1.2000' is not a whole candump line")
    with connect(str(tmp_path / "lake")) as connection:
        [(rows,)] = connection.execute("SELECT count(*) FROM events").fetchall()
    assert rows == 2
    shown = CliRunner().invoke(cli, ["decode", str(log), "--parquet", str(tmp_path / "l2")])
    assert shown.exit_code == 0, shown.output
    assert "the capture ends there, cut off; the 2 frames before it are in the dataset" \
        in shown.output


def test_a_bad_line_inside_a_capture_still_fails_the_file(tmp_path: Path) -> None:
    log = tmp_path / "unit.log"
    log.write_text("(1.000000) can0 18A#0000000001\n(1.2000\n(1.300000) can0 18A#00\n")
    [result] = decode_files([log], str(tmp_path / "lake"))
    assert result.status == "failed"
    assert result.cut_off is None
    assert "line 2: '(1.2000' is not a whole candump line" in (result.error or "")


def test_a_whole_last_line_without_a_newline_is_a_frame(tmp_path: Path) -> None:
    log = tmp_path / "unit.log"
    log.write_text(LINES + "(1.200000) can0 18A#0000000001")
    [result] = decode_files([log], str(tmp_path / "lake"))
    assert (result.status, result.frames, result.cut_off) == ("decoded", 3, None)
