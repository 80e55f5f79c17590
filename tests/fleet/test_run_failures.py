"""A fleet run meets its own dataset among the logs, and a worker that dies (found by the
attack pass: each failed on main)."""

from __future__ import annotations

import os
import signal
from pathlib import Path

import pytest
from click.testing import CliRunner

pytest.importorskip("pyarrow")

from blinkcan.cli.main import cli
from blinkcan.fleet import run
from blinkcan.fleet.run import decode_files
from blinkcan.fleet.task import decode_file

LOG = "(1.000000) can0 715#00\n(1.100000) can0 195#0800000001\n"


def _killing(source: str, **options: object) -> object:
    """The per-file task, but a worker given kill.log is SIGKILLed (the OOM killer): every
    time, or only the first time when $KILL_ONCE_MARKER names a file not there yet. At module
    level: the pool sends the task to its workers by reference."""
    marker = os.environ.get("KILL_ONCE_MARKER")
    if source.endswith("kill.log") and not (marker and os.path.exists(marker)):
        if marker:
            Path(marker).write_text("")
        os.kill(os.getpid(), signal.SIGKILL)
    return decode_file(source, **options)  # type: ignore[arg-type]


def test_a_dataset_inside_the_logs_folder_is_not_read_as_logs(tmp_path: Path) -> None:
    """`decode logs --parquet logs/lake` run again read the dataset's own .parquet files as
    logs: 'cannot decode .../x.parquet', exit 1, every re-run."""
    logs = tmp_path / "logs"
    logs.mkdir()
    (logs / "a.log").write_text(LOG)
    for _ in range(2):
        result = CliRunner().invoke(cli, ["decode", str(logs), "--parquet", str(logs / "lake")])
        assert result.exit_code == 0, result.output
        assert "cannot decode" not in result.output


def test_a_killed_local_worker_costs_no_other_file(tmp_path: Path,
                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    """-j 2 and one worker SIGKILLed (the OOM killer): every file of the run was 'failed:
    BrokenProcessPool', those never started too. Now the files are run again on a new pool
    (the killed file too, as Dask does), and each is decoded once."""
    logs = tmp_path / "logs"
    logs.mkdir()
    for name in ("a", "b", "kill", "d"):
        (logs / f"{name}.log").write_text(LOG)
    marker = tmp_path / "killed-once"
    monkeypatch.setenv("KILL_ONCE_MARKER", str(marker))
    monkeypatch.setattr(run, "decode_file", _killing)
    results = decode_files([logs], str(tmp_path / "lake"), jobs=2)
    assert marker.exists(), [(r.source, r.status, r.error) for r in results]
    # a file whose result the broken pool lost after it was written is found decoded
    assert {r.status for r in results} <= {"decoded", "skipped"}, results
    assert sorted(os.path.basename(r.source) for r in results) == [
        "a.log", "b.log", "d.log", "kill.log"]


def test_a_file_that_kills_its_worker_every_time_fails_alone(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    logs = tmp_path / "logs"
    logs.mkdir()
    for name in ("a", "b", "kill", "d"):
        (logs / f"{name}.log").write_text(LOG)
    monkeypatch.delenv("KILL_ONCE_MARKER", raising=False)
    monkeypatch.setattr(run, "decode_file", _killing)
    results = {os.path.basename(r.source): r for r in
               decode_files([logs], str(tmp_path / "lake"), jobs=2)}
    assert results["kill.log"].status == "failed"
    assert "BrokenProcessPool" in (results["kill.log"].error or "")
    assert {results[n].status for n in ("a.log", "b.log", "d.log")} <= {"decoded", "skipped"}


def test_the_run_counts_one_file_in_the_singular(tmp_path: Path) -> None:
    (tmp_path / "a.log").write_text(LOG)
    result = CliRunner().invoke(cli, ["decode", str(tmp_path / "a.log"), "--parquet",
                                      str(tmp_path / "lake")])
    assert result.exit_code == 0, result.output
    assert "1 file decoded to" in result.output


@pytest.mark.parametrize("document", ["manifest", "journal"])
def test_a_corrupt_manifest_is_said_once_and_the_file_decoded_again(
        tmp_path: Path, document: str, caplog: pytest.LogCaptureFixture) -> None:
    """A manifest (or .pending.json) nested 100,000 deep stopped the whole run: 'unexpected
    RecursionError', exit 1 (issue 23: a file that cannot be read never stops the run)."""
    log = tmp_path / "a.log"
    log.write_text(LOG)
    out = str(tmp_path / "lake")
    first = decode_file(log, out)
    [manifest] = (tmp_path / "lake" / "_blinkcan").glob("*.json")
    corrupt = manifest.with_suffix(".pending.json") if document == "journal" else manifest
    corrupt.write_text("[" * 100_000 + "]" * 100_000)
    with caplog.at_level("WARNING", logger="blinkcan.fleet.task"):
        again = decode_file(log, out)
    assert (again.status, again.frames, again.rows) == ("decoded", first.frames, first.rows)
    assert again.outputs == first.outputs
    said = [r.getMessage() for r in caplog.records if "corrupt" in r.getMessage()]
    assert said == [f"{corrupt} is corrupt (RecursionError): read as if absent"]
    result = CliRunner().invoke(cli, ["decode", str(log), "--parquet", out])
    assert result.exit_code == 0, result.output
