"""A folder of logs with links in it: hard links, symbolic links to files and folders, a
dangling link, a link loop, a named pipe (found by session 8's attack pass: a file reached by
three names was decoded three times, every frame three times in ``events``; a dangling link and
a pipe were skipped in silence)."""

from __future__ import annotations

import json
import os
import shutil
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


def _link(first: Path, second: Path, link: str) -> None:
    if link == "hard":
        os.link(first, second)
    else:
        second.symlink_to(first)


@pytest.mark.parametrize("link", ["hard", "symbolic"])
def test_another_name_of_a_decoded_file_named_alone_later_is_not_decoded_again(
        tmp_path: Path, link: str) -> None:
    """A later run that names only another name of a file the dataset has (a hard link made
    since, a link to it) finds it by the file's identity (st_dev, st_ino) in the dataset:
    the file is taken under the name it was decoded under (skipped), and the name given is
    "same" as that one. Before, it was decoded again under the new name: every frame twice."""
    first, second = tmp_path / "a.log", tmp_path / "b.log"
    first.write_text(LOG)
    lake = str(tmp_path / "lake")
    assert [r.status for r in decode_files([first], lake)] == ["decoded"]
    _link(first, second, link)
    again = decode_files([second], lake)
    assert [(r.source, r.status, r.same_as) for r in again] == \
        [(str(first), "skipped", None), (str(second), "same", str(first))]
    assert _frames(tmp_path / "lake") == _frames_of_one(tmp_path)


def test_the_command_line_says_the_name_given_is_the_same_file(tmp_path: Path) -> None:
    first, second = tmp_path / "a.log", tmp_path / "b.log"
    first.write_text(LOG)
    lake = str(tmp_path / "lake")
    assert _decode(str(first), "--parquet", lake)[0] == 0
    os.link(first, second)
    code, output = _decode(str(second), "--parquet", lake)
    assert code == 0, output
    assert f"{second}: the same file as {first} (a link): decoded once, under that name" \
        in output
    assert "0 files decoded" in output, output
    assert "1 already decoded" in output, output
    assert _frames(tmp_path / "lake") == _frames_of_one(tmp_path)


def test_a_file_grown_since_named_by_its_other_name_replaces_its_rows(tmp_path: Path) -> None:
    """The file changed since it was decoded (a logger appended to it): decoded again under
    the name it was decoded under, so its new rows replace the old ones (under the new name
    the old rows would stay beside them)."""
    first, second = tmp_path / "a.log", tmp_path / "b.log"
    first.write_text(LOG)
    lake = str(tmp_path / "lake")
    decode_files([first], lake)
    os.link(first, second)
    with second.open("a") as log:
        log.write(OTHER)
    again = decode_files([second], lake)
    assert [(r.source, r.status) for r in again] == [(str(first), "decoded"),
                                                     (str(second), "same")]
    grown = tmp_path / "grown"
    grown.mkdir()
    (grown / "a.log").write_text(LOG + OTHER)
    decode_files([grown], str(tmp_path / "lake2"))
    assert _frames(tmp_path / "lake") == _frames(tmp_path / "lake2")


def test_a_manifest_written_before_the_file_identity_was_kept_is_still_read(
        tmp_path: Path) -> None:
    """A dataset written by an older blinkcan: its manifests have no "file" (st_dev, st_ino)
    and there is no index of files; a run over the same names skips every file (no decoding
    again after an upgrade)."""
    logs = tmp_path / "logs"
    logs.mkdir()
    for name in ("a.log", "b.log"):
        (logs / name).write_text(LOG)
    lake = tmp_path / "lake"
    decode_files([logs], str(lake))
    for manifest in (lake / "_blinkcan").glob("*.json"):
        document = json.loads(manifest.read_text())
        assert isinstance(document.pop("file"), list)
        manifest.write_text(json.dumps(document))
    shutil.rmtree(lake / "_blinkcan" / "files")
    assert [r.status for r in decode_files([logs], str(lake))] == ["skipped", "skipped"]


def test_a_renamed_file_whose_old_name_now_names_another_file_is_decoded(
        tmp_path: Path) -> None:
    """The index of files is a hint: the name it points to must still name the same file.
    a.log decoded, then moved to b.log and a new a.log written: b.log is decoded (its own
    name), a.log (another file now) too."""
    first, second = tmp_path / "a.log", tmp_path / "b.log"
    first.write_text(LOG)
    lake = str(tmp_path / "lake")
    decode_files([first], lake)
    first.rename(second)
    first.write_text(OTHER)
    assert [(r.source, r.status) for r in decode_files([second, first], lake)] == \
        [(str(second), "decoded"), (str(first), "decoded")]


@pytest.mark.parametrize("entry", [b"not json", b"[1]", b'{"source": 3}',
                                   b'{"source": "/nowhere"}'])
def test_a_corrupt_or_stale_index_entry_is_no_hint(tmp_path: Path, entry: bytes) -> None:
    """The index of files is a hint: an entry that is no JSON object, names no path, or a
    path without a manifest is passed over; the name given is decoded under its own name."""
    first, second = tmp_path / "a.log", tmp_path / "b.log"
    first.write_text(LOG)
    lake = tmp_path / "lake"
    decode_files([first], str(lake))
    [index] = (lake / "_blinkcan" / "files").iterdir()
    index.write_bytes(entry)
    os.link(first, second)
    assert [(r.source, r.status) for r in decode_files([second], str(lake))] == \
        [(str(second), "decoded")]
