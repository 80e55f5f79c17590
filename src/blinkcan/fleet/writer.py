"""Rows into Parquet files, one per (model, date) partition, in row groups of bounded size.

Rows are gathered column by column (a Python list per column and partition, appended to by
the caller: no tuple per row, no transposing); at ``rows_per_group`` rows in all the
partitions' columns become Arrow arrays, once per row group, and a row group each, so memory
stays the same whatever the log's size. Files go to a folder of the caller's choice (the
caller renames them into the dataset once the whole log is decoded).
"""

from __future__ import annotations

import datetime
import math
from typing import Any

import pyarrow as pa
import pyarrow.parquet as pq
from fsspec import AbstractFileSystem

from blinkcan.fleet.schema import ROWS_PER_GROUP, SCHEMA, UNKNOWN

_EPOCH_ORDINAL = datetime.date(1970, 1, 1).toordinal()
_DAY_S = 86_400
#: times a Parquet timestamp in microseconds carries (years 1..9999)
_EARLIEST_S, _LATEST_S = -62_135_596_800, 253_402_300_800
_INT64 = 1 << 63
_COLUMNS = [field.name for field in SCHEMA if field.name != "source"]


def partition_path(model: str, date: str) -> str:
    return f"model={model}/date={date}"


class PartitionWriter:
    """Appends rows to the partitions of one source file; :meth:`close` says which files."""

    def __init__(self, fs: AbstractFileSystem, folder: str, name: str, source: str,
                 rows_per_group: int = ROWS_PER_GROUP) -> None:
        if rows_per_group < 1:
            raise ValueError(f"rows_per_group must be 1 or more, not {rows_per_group}")
        self._fs, self._folder, self._name, self._source = fs, folder, name, source
        self._rows_per_group = rows_per_group
        #: partition -> its columns so far (the schema's but ``source``, in its order)
        self._buffers: dict[tuple[str, str], list[list[Any]]] = {}
        self._writers: dict[tuple[str, str], tuple[Any, pq.ParquetWriter]] = {}
        self._buffered = 0
        self._days: dict[int, str] = {}
        self._day = (0.0, 0.0, UNKNOWN)  # the day of the last time: [start, end) and its date
        #: rows written so far
        self.rows = 0

    def time_and_date(self, seconds: float) -> tuple[int | None, str]:
        """(microseconds since the epoch, the UTC date) of a log time; (None, "unknown")
        for one no timestamp carries (not finite, before year 1 or after 9999)."""
        start, end, today = self._day
        if start <= seconds < end:  # a log's times are mostly of one day
            return round(seconds * 1_000_000), today
        if not (math.isfinite(seconds) and _EARLIEST_S <= seconds < _LATEST_S):
            return None, UNKNOWN
        day = int(seconds // _DAY_S)
        date = self._days.get(day)
        if date is None:
            date = self._days[day] = datetime.date.fromordinal(_EPOCH_ORDINAL + day).isoformat()
        self._day = (day * _DAY_S, (day + 1) * _DAY_S, date)
        return round(seconds * 1_000_000), date

    @property
    def rows_per_group(self) -> int:
        return self._rows_per_group

    def columns(self, partition: tuple[str, str]) -> list[list[Any]]:
        """The partition's column lists (the schema's columns but ``source``, in its order),
        for the caller to append a row to; it calls :meth:`added` with how many it appended
        (or :meth:`flush` itself). The lists stay the same for the writer's life."""
        columns = self._buffers.get(partition)
        if columns is None:
            columns = self._buffers[partition] = [[] for _ in _COLUMNS]
        return columns

    def added(self, rows: int) -> None:
        """``rows`` rows were appended to :meth:`columns`: a row group when enough."""
        self._buffered += rows
        if self._buffered >= self._rows_per_group:
            self.flush()

    def append(self, partition: tuple[str, str], row: tuple[Any, ...]) -> None:
        """A row of the partition: the values of the schema's columns but ``source``, in its
        order."""
        for column, value in zip(self.columns(partition), row, strict=True):
            column.append(value)
        self.added(1)

    def flush(self) -> None:
        """Every partition's rows so far as a row group."""
        for partition, columns in self._buffers.items():
            count = len(columns[0])
            if not count:
                continue
            arrays = [pa.array(values, type=SCHEMA.field(name).type)
                      for name, values in zip(_COLUMNS, columns, strict=True)]
            arrays.insert(SCHEMA.get_field_index("source"),
                          pa.repeat(pa.scalar(self._source, pa.string()), count))
            self._writer(partition).write_table(pa.Table.from_arrays(arrays, schema=SCHEMA))
            self.rows += count
            for column in columns:
                column.clear()  # the same lists: the caller's appends stay bound to them
        self._buffered = 0

    def _writer(self, partition: tuple[str, str]) -> pq.ParquetWriter:
        entry = self._writers.get(partition)
        if entry is None:
            folder = f"{self._folder}/{partition_path(*partition)}"
            self._fs.makedirs(folder, exist_ok=True)
            stream = self._fs.open(f"{folder}/{self._name}", "wb")
            entry = self._writers[partition] = (stream, pq.ParquetWriter(stream, SCHEMA))
        return entry[1]

    def close(self) -> list[str]:
        """Write what is left and close the files; their paths relative to the folder."""
        self.flush()
        written = []
        for partition, (stream, writer) in sorted(self._writers.items()):
            writer.close()
            stream.close()
            written.append(f"{partition_path(*partition)}/{self._name}")
        self._writers.clear()
        return written

    def abandon(self) -> None:
        """Close the files without finishing them (the caller removes the folder)."""
        for stream, writer in self._writers.values():
            try:
                writer.close()
            finally:
                stream.close()
        self._writers.clear()


def int64_or_none(value: int | None) -> int | None:
    return value if value is None or -_INT64 <= value < _INT64 else None
