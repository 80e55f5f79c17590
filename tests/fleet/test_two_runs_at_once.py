"""Two runs at once on one dataset (a typical mistake: a cron job and a hand-started run):
each file is decoded by one of them at a time, the other finds it decoded. Before, the second
run's task took the first's attempt folder for a dead predecessor's and removed it while the
first was still writing there: the first run ended with "cannot use .../_blinkcan/tmp/...:
No such file or directory", and now and then the dataset had a file's rows more than once."""

from __future__ import annotations

import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

import pytest

pytest.importorskip("pyarrow")
import duckdb

from blinkcan.fleet import task
from blinkcan.fleet.task import FileResult, decode_file
from tests.fleet.logs import fleet_traffic, write_log


def _rows(lake: Path) -> int:
    query = f"SELECT count(*) FROM read_parquet('{lake}/**/*.parquet', hive_partitioning=1)"
    return int(duckdb.connect().execute(query).fetchall()[0][0])


def test_a_file_decoded_by_two_tasks_at_once_is_decoded_once(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    log = write_log(tmp_path / "boat.log", fleet_traffic(3))
    lake = tmp_path / "lake"
    started, go = threading.Event(), threading.Event()
    decode_into = task._decode_into

    def held(*args: Any) -> Any:
        """The first task holds in the middle of its decoding until told to go on."""
        if not started.is_set():
            started.set()
            assert go.wait(30)
        return decode_into(*args)

    monkeypatch.setattr(task, "_decode_into", held)
    results: dict[str, FileResult | BaseException] = {}

    def run(name: str) -> None:
        try:
            results[name] = decode_file(log, str(lake))
        except BaseException as error:
            results[name] = error

    first = threading.Thread(target=run, args=("first",))
    first.start()
    assert started.wait(30)
    second = threading.Thread(target=run, args=("second",))
    second.start()
    time.sleep(0.5)  # the second task does what it does while the first holds
    go.set()
    first.join(60)
    second.join(60)
    statuses = sorted(r.status if isinstance(r, FileResult) else repr(r)
                      for r in results.values())
    assert statuses == ["decoded", "skipped"], results
    alone = tmp_path / "alone"
    decode_file(log, str(alone))
    assert _rows(lake) == _rows(alone)


def test_two_command_line_runs_at_once_both_end_well(tmp_path: Path) -> None:
    logs = tmp_path / "logs"
    logs.mkdir()
    traffic = fleet_traffic(3)
    for n in range(3):
        write_log(logs / f"boat{n}.log", traffic * 6)
    lake = tmp_path / "lake"
    command = [sys.executable, "-m", "blinkcan", "decode", str(logs), "--parquet", str(lake)]
    runs = [subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                             text=True) for _ in range(2)]
    outputs = [run.communicate(timeout=300)[0] for run in runs]
    assert [run.returncode for run in runs] == [0, 0], outputs
    alone = tmp_path / "alone"
    for log in sorted(logs.iterdir()):
        decode_file(log, str(alone))
    assert _rows(lake) == _rows(alone)
