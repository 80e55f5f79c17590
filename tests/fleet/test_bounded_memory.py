"""Memory per file stays the same whatever the log's size (issue 23: "bounded memory per file
(row groups), whatever the file's size"). A Parquet writer holds each row group's metadata
until its file is closed (some 11 kB a row group: +23 MB from a 1 M-frame log to a 10 M one),
so a partition's file is closed after writer.GROUPS_PER_FILE row groups and its rows go on in
its next file, and a date's files are closed once the log's time has passed it. The Python
heap's peak is the same for a log and for twice that log (tracemalloc: no timing)."""

from __future__ import annotations

import tracemalloc
from pathlib import Path

import pyarrow.dataset as ds
import pyarrow.parquet as pq
import pytest
from benchmarks.realistic_log import device_nodes, realistic_traffic

from blinkcan.fleet import writer
from blinkcan.fleet.task import decode_file
from tests.fleet.logs import EPOCH, candump_lines, fleet_traffic


def _rows(out: Path) -> list[dict[str, object]]:
    table = ds.dataset(out, format="parquet", partitioning="hive").to_table()
    rows: list[dict[str, object]] = table.sort_by([("time", "ascending"), ("can_id", "ascending"),
                          ("kind", "ascending"), ("key", "ascending"),
                          ("pin", "ascending")]).to_pylist()
    return rows


def test_a_partition_goes_on_in_its_next_file_after_so_many_row_groups(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Every file has GROUPS_PER_FILE row groups at most; the rows are those of one file
    per partition, each partition's in order."""
    log = tmp_path / "unit.log"
    log.write_text("".join(candump_lines(fleet_traffic())))
    whole = decode_file(log, str(tmp_path / "whole"), rows_per_group=40)
    monkeypatch.setattr(writer, "GROUPS_PER_FILE", 3)
    split = decode_file(log, str(tmp_path / "split"), rows_per_group=40)
    assert split.rows == whole.rows
    assert len(split.outputs) > len(whole.outputs)
    assert max(pq.ParquetFile(tmp_path / "split" / p).num_row_groups
               for p in split.outputs) <= 3
    assert _rows(tmp_path / "split") == _rows(tmp_path / "whole")
    for output in whole.outputs:  # a partition's files, in order, are its one file's rows
        folder = output.rsplit("/", 1)[0]
        parts = [p for p in split.outputs if p.rsplit("/", 1)[0] == folder]
        assert [r for p in parts for r in pq.read_table(tmp_path / "split" / p).to_pylist()] \
            == pq.read_table(tmp_path / "whole" / output).to_pylist()


def test_a_dates_files_are_closed_once_the_log_has_passed_it(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The fleet log crosses midnight: the first date's files are finished while the second
    date's rows are still being written, not at the end."""
    log = tmp_path / "unit.log"
    log.write_text("".join(candump_lines(fleet_traffic())))
    finished: list[tuple[str, int]] = []
    finish = writer.PartitionWriter._finish

    def recording(self: writer.PartitionWriter, partition: tuple[str, str]) -> None:
        if partition in self._writers:
            finished.append((partition[1], self.rows))
        finish(self, partition)

    monkeypatch.setattr(writer.PartitionWriter, "_finish", recording)
    result = decode_file(log, str(tmp_path / "lake"), rows_per_group=40)
    dates = sorted({date for date, _ in finished})
    assert len(dates) == 2  # 31 May and 1 June
    assert all(rows < result.rows for date, rows in finished if date == dates[0])


def _peak(log: Path, out: Path) -> int:
    """The Python heap's peak while the log is decoded (bytes over what it was before)."""
    tracemalloc.start()
    try:
        before = tracemalloc.get_traced_memory()[0]
        decode_file(log, str(out), devices=device_nodes(), rows_per_group=2_000)
        return tracemalloc.get_traced_memory()[1] - before
    finally:
        tracemalloc.stop()


def test_the_heap_of_a_log_twice_as_long_peaks_as_high(tmp_path: Path) -> None:
    """The realistic log of every model (2,000 frames) ten times over and twenty times over
    (each copy's times after the one before, as benchmarks/memory.py): the same peak, give or
    take a few per cent. (Below some 20,000 frames the peak still grows: the decoder's and the
    fleet's caches of what frames made fill up to their bounds. Nothing grows per frame.)"""
    traffic = realistic_traffic(2_000)
    span = traffic[-1][0] - traffic[0][0] + 1.0
    logs = []
    for copies in (10, 20):
        log = tmp_path / f"{copies}.log"
        log.write_text("".join(candump_lines([(EPOCH + n * span + t, f)
                                              for n in range(copies) for t, f in traffic])))
        logs.append(log)
    small, large = (_peak(log, tmp_path / log.stem) for log in logs)
    assert large < small * 1.05 + 100_000, (small, large)
