"""A folder of logs with links in it: hard links, symbolic links to files and folders, a
dangling link, a link loop, a named pipe (found by session 8's attack pass: a file reached by
three names was decoded three times, every frame three times in ``events``; a dangling link and
a pipe were skipped in silence)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from click.testing import CliRunner

pytest.importorskip("pyarrow")
import duckdb

from blinkcan.cli.main import cli
from blinkcan.fleet.run import decode_files, log_files

LOG = "(1.000000) can0 715#00\n(1.100000) can0 195#0800000001\n"
OTHER = "(2.000000) can0 70C#05\n"


def _frames(lake: Path) -> int:
    query = f"SELECT count(*) FROM read_parquet('{lake}/**/*.parquet', hive_partitioning=1)"
    return int(duckdb.connect().execute(query).fetchall()[0][0])


def _decode(*arguments: str) -> tuple[int, str]:
    result = CliRunner().invoke(cli, ["decode", *arguments])
    return result.exit_code, result.output


def test_a_file_reached_by_three_names_is_decoded_once(tmp_path: Path) -> None:
    logs = tmp_path / "logs"
    logs.mkdir()
    (logs / "a.log").write_text(LOG)
    os.link(logs / "a.log", logs / "b.log")
    (logs / "c.log").symlink_to("a.log")
    code, output = _decode(str(logs), "--parquet", str(tmp_path / "lake"))
    assert code == 0, output
    assert "1 file decoded" in output
    assert "2 other names of a file listed (links) not decoded twice" in output
    for name in ("b.log", "c.log"):
        assert f"{logs / name}: the same file as {logs / 'a.log'}" in output
    assert _frames(tmp_path / "lake") == _frames_of_one(tmp_path)


def _frames_of_one(tmp_path: Path) -> int:
    single = tmp_path / "single"
    single.mkdir()
    (single / "a.log").write_text(LOG)
    decode_files([single], str(tmp_path / "lake1"))
    return _frames(tmp_path / "lake1")


def test_the_same_file_named_twice_on_the_command_line_is_decoded_once(tmp_path: Path) -> None:
    (tmp_path / "a.log").write_text(LOG)
    os.link(tmp_path / "a.log", tmp_path / "b.log")
    results = decode_files([tmp_path / "a.log", tmp_path / "b.log", tmp_path / "a.log"],
                           str(tmp_path / "lake"))
    assert [r.status for r in results] == ["decoded", "same"]
    assert results[1].same_as == str(tmp_path / "a.log")


def test_a_linked_folder_is_read_and_a_link_loop_ends(tmp_path: Path) -> None:
    """A link to a folder is the user's way to include it (a boat's USB stick); a link back to
    an ancestor is a loop: each real folder is read once."""
    elsewhere = tmp_path / "stick"
    elsewhere.mkdir()
    (elsewhere / "boat7.log").write_text(OTHER)
    logs = tmp_path / "logs"
    logs.mkdir()
    (logs / "a.log").write_text(LOG)
    (logs / "boat7").symlink_to(elsewhere)
    (logs / "up").symlink_to("..")
    (elsewhere / "back").symlink_to(logs)
    found = log_files([logs])
    assert found == [str(logs / "a.log"), str(logs / "boat7" / "boat7.log")]


def test_a_dangling_link_is_named_and_counted(tmp_path: Path) -> None:
    logs = tmp_path / "logs"
    logs.mkdir()
    (logs / "a.log").write_text(LOG)
    (logs / "gone.log").symlink_to("nowhere.log")
    (logs / "loop.log").symlink_to("loop.log")
    code, output = _decode(str(logs), "--parquet", str(tmp_path / "lake"))
    assert code == 1, output
    assert f"cannot decode {logs / 'gone.log'}" in output
    assert f"cannot decode {logs / 'loop.log'}" in output
    assert "2 of 3 files could not be decoded" in output


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="named pipes are POSIX")
def test_a_named_pipe_in_the_folder_is_named(tmp_path: Path) -> None:
    """Named on the command line it was refused (fleet/sources.py); in a folder it was
    skipped in silence."""
    logs = tmp_path / "logs"
    logs.mkdir()
    (logs / "a.log").write_text(LOG)
    os.mkfifo(logs / "live.log")
    code, output = _decode(str(logs), "--parquet", str(tmp_path / "lake"))
    assert code == 1, output
    assert f"cannot decode {logs / 'live.log'}: {logs / 'live.log'} is a FIFO" in output


def test_the_count_of_files_leaves_out_the_dataset_in_the_folder(tmp_path: Path) -> None:
    logs = tmp_path / "logs"
    logs.mkdir()
    (logs / "a.log").write_text(LOG)
    (logs / "gone.log").symlink_to("nowhere.log")
    _decode(str(logs), "--parquet", str(logs / "lake"))
    code, output = _decode(str(logs), "--parquet", str(logs / "lake"))
    assert code == 1
    assert "1 of 2 files could not be decoded" in output


def test_a_dataset_reached_by_a_link_in_the_folder_is_not_read_as_logs(tmp_path: Path) -> None:
    logs = tmp_path / "logs"
    logs.mkdir()
    (logs / "a.log").write_text(LOG)
    lake = tmp_path / "lake"
    (logs / "lake").symlink_to(lake)
    for _ in range(2):
        code, output = _decode(str(logs), "--parquet", str(lake))
        assert code == 0, output
        assert "cannot decode" not in output


@pytest.mark.parametrize("link", ["hard", "symbolic"])
def test_names_of_one_file_given_in_another_order_later_are_not_decoded_again(
        tmp_path: Path, link: str) -> None:
    """A later run that lists the names of one file in another order finds it decoded under
    the name it was decoded under before: skipped, the other names "same" as that one. Before,
    the first name of the later run was decoded again, under its own name, and every frame of
    the file was twice in the dataset."""
    first, second = tmp_path / "a.log", tmp_path / "b.log"
    first.write_text(LOG)
    if link == "hard":
        os.link(first, second)
    else:
        second.symlink_to(first)
    lake = str(tmp_path / "lake")
    assert [r.status for r in decode_files([first, second], lake)] == ["decoded", "same"]
    again = decode_files([second, first], lake)
    assert [(r.status, r.same_as) for r in again] == [("same", str(first)), ("skipped", None)]
    assert _frames(tmp_path / "lake") == _frames_of_one(tmp_path)
