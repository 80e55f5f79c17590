"""A line python-can's readers read as a message that is no frame (a CSV or TRC line with a
time of inf, a 48-bit identifier, a DLC of 99 over one byte; a SQLite row with no time) is an
unreadable line in its place, as a line they cannot read is: ``decode`` shows it and goes on,
``convert`` names it and keeps every frame around it. Before, such a message reached the
decoder and the writers: ``decode`` ended with "unexpected ValueError: 29-bit identifier
must be 0..0x1fffffff", ``convert`` to .pcap with "unexpected OverflowError", and a SQLite
row with no time with "unexpected TypeError"."""

from __future__ import annotations

import sqlite3
from pathlib import Path

import pytest
from click.testing import CliRunner

from blinkcan.cli.main import cli
from blinkcan.formats.logs import UnreadableLine, read_messages

CSV = ("timestamp,arbitration_id,extended,remote,error,dlc,data\n"
       "1.0,0x123,0,0,0,1,AQ==\n"
       "1e999,0x123,0,0,0,1,AQ==\n"          # line 3: time inf
       "2.0,0xFFFFFFFFFFFF,1,0,0,1,AQ==\n"   # line 4: a 48-bit identifier
       "3.0,0x123,0,0,0,99,AQ==\n"           # line 5: DLC 99, one byte
       "4.0,0x124,0,0,0,1,Ag==\n")
TRC = (";$FILEVERSION=2.1\n;$STARTTIME=45000.5\n;$COLUMNS=N,O,T,I,d,l,D\n"
       " 1 1000.000 DT 0123 Rx 1 01\n"
       " 2 1001.000 DT 0123 Rx 15 01\n"      # line 5: DLC 15, one byte
       " 3 1002.000 DT 0124 Rx 1 02\n")


@pytest.fixture(params=["csv", "trc", "db"])
def log(request: pytest.FixtureRequest, tmp_path: Path) -> tuple[Path, list[int]]:
    """A log of two frames (123h 01, 124h 02) around lines that are no frames, and their
    numbers."""
    path = tmp_path / f"bad.{request.param}"
    if request.param == "csv":
        path.write_text(CSV)
        return path, [3, 4, 5]
    if request.param == "trc":
        path.write_text(TRC)
        return path, [5]
    with sqlite3.connect(path) as database:
        database.execute("CREATE TABLE messages (ts REAL, arbitration_id INTEGER, "
                         "extended INTEGER, remote INTEGER, error INTEGER, dlc INTEGER, "
                         "data BLOB)")
        for row in [(1.0, 0x123, 0, 0, 0, 1, b"\x01"), (None, 0x123, 0, 0, 0, 1, b"\x01"),
                    (2.0, 2**40, 0, 0, 0, 1, b"\x01"), (4.0, 0x124, 0, 0, 0, 1, b"\x02")]:
            database.execute("INSERT INTO messages VALUES (?, ?, ?, ?, ?, ?, ?)", row)
    database.close()
    return path, [2, 3]


def test_each_is_unreadable_in_its_place(log: tuple[Path, list[int]]) -> None:
    path, numbers = log
    items = list(read_messages(path, unreadable=True))
    assert [item.number for item in items if isinstance(item, UnreadableLine)] == numbers
    frames = [item for item in items if not isinstance(item, UnreadableLine)]
    assert [(m.arbitration_id, bytes(m.data)) for m in frames] == \
        [(0x123, b"\x01"), (0x124, b"\x02")]
    assert isinstance(items[0], UnreadableLine) is False
    assert isinstance(items[-1], UnreadableLine) is False


@pytest.mark.parametrize("suffix", [".pcap", ".log", ".asc", ".blf"])
def test_convert_names_them_and_keeps_the_frames(
        log: tuple[Path, list[int]], tmp_path: Path, suffix: str) -> None:
    path, numbers = log
    target = tmp_path / f"out{suffix}"
    result = CliRunner().invoke(cli, ["convert", str(path), str(target)])
    assert result.exit_code == 1, result.output
    assert "unexpected" not in result.output
    assert "2 frames written" in result.output
    assert f"{len(numbers)} " in result.output  # "N lines could not be read"
    assert [(m.arbitration_id, bytes(m.data)) for m in read_messages(target)] == \
        [(0x123, b"\x01"), (0x124, b"\x02")]


def test_decode_shows_them_and_goes_on(log: tuple[Path, list[int]]) -> None:
    path, numbers = log
    result = CliRunner().invoke(cli, ["decode", "--json", str(path)])
    assert result.exit_code == 0, result.output
    assert "unexpected" not in result.output
    assert result.output.count('"kind":"unreadable"') == len(numbers)


def test_a_time_pcap_cannot_hold_is_one_line_and_the_frames_before_it_are_kept(
        tmp_path: Path) -> None:
    """Before: "unexpected error: argument out of range"."""
    source = tmp_path / "relative.log"
    source.write_text("(1.0) can0 123#01\n(-5.0) can0 123#02\n")
    target = tmp_path / "out.pcap"
    result = CliRunner().invoke(cli, ["convert", str(source), str(target)])
    assert result.exit_code == 1
    assert "unexpected" not in result.output
    assert "a pcap packet's time is 0..4294967294 s since 1970, not -5.0" in result.output
    assert [bytes(m.data) for m in read_messages(target)] == [b"\x01"]
