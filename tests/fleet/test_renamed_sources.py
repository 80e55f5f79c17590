"""A decoded log renamed (``mv a.log b.log``) and decoded under its new name: its rows were
in the dataset twice (the old name's outputs stayed, the new name's were added). The file is
known by its identity (st_dev, st_ino) in its old manifest: unchanged, it is skipped and said;
changed, its new decoding replaces the old name's rows, never adds to them."""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest
from click.testing import CliRunner

pytest.importorskip("pyarrow")
import duckdb

from blinkcan.cli.main import cli
from blinkcan.fleet.run import decode_files
from blinkcan.fleet.task import source_key

LOG = "(1.000000) can0 715#00\n(1.100000) can0 195#0800000001\n"
MORE = "(2.000000) can0 70C#05\n"


def _sources(lake: Path) -> list[tuple[str, int]]:
    """(source, rows) of the dataset, by source."""
    query = (f"SELECT source, count(*) FROM read_parquet('{lake}/**/*.parquet', "
             "hive_partitioning=1) GROUP BY source ORDER BY source")
    return [(str(s), int(n)) for s, n in duckdb.connect().execute(query).fetchall()]


def _rows_of(text: str, tmp_path: Path) -> int:
    """The rows one decoding of a log holding ``text`` gives."""
    alone = tmp_path / "alone"
    alone.mkdir(exist_ok=True)
    (alone / "x.log").write_text(text)
    lake = tmp_path / f"alone-lake-{len(text)}"
    decode_files([alone / "x.log"], str(lake))
    return sum(n for _, n in _sources(lake))


def test_a_renamed_unchanged_file_is_skipped_and_said(tmp_path: Path) -> None:
    first, second = tmp_path / "a.log", tmp_path / "b.log"
    first.write_text(LOG)
    lake = tmp_path / "lake"
    decode_files([first], str(lake))
    before = _sources(lake)
    first.rename(second)
    for _run in range(2):  # and again: still the file decoded before, never twice
        results = decode_files([second], str(lake))
        assert [(r.source, r.status, r.same_as) for r in results] == \
            [(str(second), "skipped", str(first))]
        assert results[0].rows == before[0][1]
        assert _sources(lake) == before


def test_the_command_line_says_the_file_was_decoded_before_under_its_old_name(
        tmp_path: Path) -> None:
    logs = tmp_path / "logs"
    logs.mkdir()
    (logs / "a.log").write_text(LOG)
    (logs / "c.log").write_text(MORE)
    lake = tmp_path / "lake"
    result = CliRunner().invoke(cli, ["decode", str(logs), "--parquet", str(lake)])
    assert result.exit_code == 0, result.output
    before = _sources(lake)
    (logs / "a.log").rename(logs / "b.log")
    result = CliRunner().invoke(cli, ["decode", str(logs), "--parquet", str(lake)])
    assert result.exit_code == 0, result.output
    assert (f"{logs / 'b.log'}: the file decoded before as {logs / 'a.log'} (renamed): not "
            "decoded again") in result.output
    assert "0 files decoded" in result.output
    assert "2 already decoded" in result.output
    assert _sources(lake) == before


@pytest.mark.parametrize("force", [False, True])
def test_a_renamed_file_changed_or_forced_replaces_its_old_rows(tmp_path: Path,
                                                                force: bool) -> None:
    """Grown since (a logger still writing) or --force: decoded under its new name, the old
    name's rows and manifest removed: the rows of the file once, under the name it has."""
    first, second = tmp_path / "a.log", tmp_path / "b.log"
    first.write_text(LOG)
    lake = tmp_path / "lake"
    decode_files([first], str(lake))
    first.rename(second)
    text = LOG if force else LOG + MORE
    if not force:
        with second.open("a") as stream:
            stream.write(MORE)
    results = decode_files([second], str(lake), force=force)
    assert [(r.source, r.status, r.same_as) for r in results] == [(str(second), "decoded", None)]
    assert _sources(lake) == [(str(second), _rows_of(text, tmp_path))]
    assert not (lake / "_blinkcan" / f"{source_key(str(first))}.json").exists()
    assert [r.status for r in decode_files([second], str(lake))] == ["skipped"]


def test_a_renamed_file_of_an_older_manifest_is_decoded_as_before(tmp_path: Path) -> None:
    """A manifest without the file's identity (an older blinkcan's) cannot say the renamed
    file is the one it decoded: decoded under its new name, as before (the old rows stay)."""
    first, second = tmp_path / "a.log", tmp_path / "b.log"
    first.write_text(LOG)
    lake = tmp_path / "lake"
    decode_files([first], str(lake))
    manifest = lake / "_blinkcan" / f"{source_key(str(first))}.json"
    document = json.loads(manifest.read_text())
    del document["file"]
    manifest.write_text(json.dumps(document))
    first.rename(second)
    assert [(r.source, r.status, r.same_as) for r in decode_files([second], str(lake))] == \
        [(str(second), "decoded", None)]
    assert manifest.exists()


def test_a_renamed_file_given_with_a_hard_link_is_decoded_once(tmp_path: Path) -> None:
    """Renamed, and a hard link made to it: both names are the file decoded before."""
    first, second, third = tmp_path / "a.log", tmp_path / "b.log", tmp_path / "c.log"
    first.write_text(LOG)
    lake = tmp_path / "lake"
    decode_files([first], str(lake))
    before = _sources(lake)
    first.rename(second)
    os.link(second, third)
    results = decode_files([second, third], str(lake))
    assert [(r.source, r.status, r.same_as) for r in results] == \
        [(str(second), "skipped", str(first)), (str(third), "same", str(second))]
    assert _sources(lake) == before
