"""Rows into Parquet files, one per (model, date) partition, in row groups of bounded size.

The caller gathers a row group's rows column by column (:class:`~blinkcan.fleet.frames.Segment`:
a list per column, per frame, and per row the number of its detail among the segment's distinct
ones); :meth:`PartitionWriter.write` makes each column one Arrow array (the distinct details
converted once and taken for the rows, the frame's columns repeated for its rows by one
``take``), the times
with Arrow's arithmetic, and writes each partition's rows as a row group (one stable sort by
partition, then slices). A Parquet file holds every row group's metadata (some 11 kB each)
until it is closed, so a partition's file is closed once it has :data:`GROUPS_PER_FILE` row
groups (its rows go on in the partition's next file: ``<name>-2.parquet``, ...), and once the
log's time has passed its date (a log is in time order: no more rows come for it; a row that
does starts the partition's next file). So memory stays the same whatever the log's size.
Files go to a folder of the caller's choice (the caller renames them into the dataset once the
whole log is decoded).
"""

from __future__ import annotations

import datetime
import math
from collections.abc import Callable, Iterable
from typing import TYPE_CHECKING, Any

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.parquet as pq

from blinkcan.fleet.frames import Segment
from blinkcan.fleet.rows import Detail
from blinkcan.fleet.schema import ROWS_PER_GROUP, SCHEMA, UNKNOWN

if TYPE_CHECKING:
    from fsspec import AbstractFileSystem

    from blinkcan.fleet.local_files import LocalFiles

_EPOCH_ORDINAL = datetime.date(1970, 1, 1).toordinal()
#: row groups in one file of a partition before its next file is begun (at most some 0.7 MB of
#: metadata held per file open; 4 M rows in full row groups)
GROUPS_PER_FILE = 64
_DAY_S = 86_400
#: times a Parquet timestamp in microseconds carries (years 1..9999)
_EARLIEST_S, _LATEST_S = -62_135_596_800, 253_402_300_800
_INT64 = 1 << 63
_COLUMNS = [field.name for field in SCHEMA if field.name != "source"]
_SOURCE = SCHEMA.get_field_index("source")
_TIME = SCHEMA.field("time").type
#: a row's detail (rows.Detail) as the schema's columns
_DETAILS = pa.struct([SCHEMA.field(name) for name in Detail._fields])
#: columns of a value per frame (a dictionary of them costs time and space for nothing)
_UNIQUE = ("time", "data")
#: columns whose min and max in a row group select nothing (a group holds every state and
#: colour of its keys and pins; texts and data are per frame): no statistics, which cost
#: a comparison per row (issue 23: CPU per frame)
_UNSELECTIVE = ("state", "colour", "text", "data")
#: Parquet's dictionary encoding where values repeat; min/max statistics (which readers use
#: to skip row groups and files: time, source, ids, kinds, keys) on the others
_PARQUET_OPTIONS = {
    "use_dictionary": [name for name in SCHEMA.names if name not in _UNIQUE],
    "write_statistics": [name for name in SCHEMA.names if name not in _UNSELECTIVE],
}
#: microseconds in a second, typed: a bare float would make Arrow infer its type,
#: which imports dateutil (start-up)
_MICROS = pa.scalar(1_000_000.0, pa.float64())


def partition_path(model: str, date: str) -> str:
    return f"model={model}/date={date}"


class PartitionWriter:
    """Writes the rows of one source file to its partitions; :meth:`close` says which files."""

    def __init__(self, fs: AbstractFileSystem | LocalFiles, folder: str, name: str, source: str,
                 rows_per_group: int = ROWS_PER_GROUP) -> None:
        if rows_per_group < 1:
            raise ValueError(f"rows_per_group must be 1 or more, not {rows_per_group}")
        self._fs, self._folder, self._name, self._source = fs, folder, name, source
        self._rows_per_group = rows_per_group
        #: the open file of each partition: its stream, its writer, its row groups so far
        self._writers: dict[tuple[str, str], tuple[Any, pq.ParquetWriter, list[int]]] = {}
        #: the files of each partition begun so far (a partition's next file is numbered on)
        self._files: dict[tuple[str, str], list[str]] = {}
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
        self._day = (day * _DAY_S, (day + 1) * _DAY_S, self._date(day))
        return round(seconds * 1_000_000), self._day[2]

    def _date(self, day: int) -> str:
        date = self._days.get(day)
        if date is None:
            date = self._days[day] = datetime.date.fromordinal(_EPOCH_ORDINAL + day).isoformat()
        return date

    def times_and_dates(self, seconds: list[float] | pa.DoubleArray
                        ) -> tuple[pa.Array, str | list[str]]:
        """:meth:`time_and_date` of many times: the microseconds as an Arrow timestamp array,
        and the date of them all where they are of one day (a log's mostly are), else each
        time's date. The same figures either way (Arrow rounds half to even, as Python)."""
        times = seconds if isinstance(seconds, pa.Array) else pa.array(seconds, pa.float64())
        if len(times) and pc.all(pc.is_finite(times)).as_py():
            extremes = pc.min_max(times)
            low, high = extremes["min"].as_py(), extremes["max"].as_py()
            day = int(low // _DAY_S)
            if low >= _EARLIEST_S and high < _LATEST_S and \
                    day * _DAY_S <= low and high < (day + 1) * _DAY_S:
                micros = pc.round(pc.multiply(times, _MICROS), round_mode="half_to_even")
                return pc.cast(pc.cast(micros, pa.int64()), _TIME), self._date(day)
        pairs = [self.time_and_date(s) for s in times.to_pylist()]
        return pa.array([p[0] for p in pairs], _TIME), [p[1] for p in pairs]

    @property
    def rows_per_group(self) -> int:
        return self._rows_per_group

    def write(self, segment: Segment) -> None:
        """The segment's rows, a row group in each partition it has rows in."""
        frames = len(segment)
        if not frames:
            return
        rows = segment.rows
        # the frame of each row, where a frame has several (numpy: no Python list of them)
        index: np.ndarray[Any, np.dtype[np.int32]] | None = None
        if rows != frames:
            counts = np.ones(frames, np.int32)
            counts[segment.multiple] = segment.counts
            index = np.repeat(np.arange(frames, dtype=np.int32), counts)
        seconds, channels, ids, extended, data = segment.frame_arrays()
        micros, dates = self.times_and_dates(seconds)
        frame_columns = {
            "time": micros, "channel": channels, "can_id": ids, "extended": extended,
            "node": pa.array(segment.nodes, pa.int16()),
            "text": pa.array(segment.texts, pa.string()), "data": data,
        }
        details = pa.array(segment.codes, pa.int32())  # each row's number in segment.details
        partitions, codes = _partitions(segment.models, dates)
        sizes = [rows]
        take: pa.Array | None = None if index is None else pa.array(index)
        if len(partitions) > 1:  # the rows by partition (a stable sort: each keeps its order)
            row_codes = codes if index is None else codes[index]
            order = np.argsort(row_codes, kind="stable")  # a radix sort for 16-bit codes
            sizes = np.bincount(row_codes, minlength=len(partitions)).tolist()
            take = pa.array(order if index is None else index[order])
            details = details.take(pa.array(order))
        row_details = _detail_struct(segment.details).take(details)
        if take is not None:  # each row's frame columns: one take per column
            frame_columns = {name: array.take(take) for name, array in frame_columns.items()}
        arrays = [frame_columns[name] if name in frame_columns else row_details.field(name)
                  for name in _COLUMNS]
        arrays.insert(_SOURCE, pa.repeat(pa.scalar(self._source, pa.string()), rows))
        table = pa.Table.from_arrays(arrays, schema=SCHEMA)
        offset = 0
        for partition, size in zip(partitions, sizes, strict=True):
            _, writer, groups = self._writer(partition)
            writer.write_table(table.slice(offset, size))
            offset += size
            groups[0] += 1
            if groups[0] >= GROUPS_PER_FILE:
                self._finish(partition)
        self.rows += rows
        today = dates if isinstance(dates, str) else min(
            (date for date in dates if date != UNKNOWN), default=UNKNOWN)
        if today != UNKNOWN:  # the files of dates the log's time has passed: closed
            for partition in [p for p in self._writers if UNKNOWN != p[1] < today]:
                self._finish(partition)

    def _finish(self, partition: tuple[str, str]) -> None:
        """A partition's open file closed (written whole: its footer)."""
        entry = self._writers.pop(partition, None)
        if entry is None:
            return
        stream, writer, _ = entry
        writer.close()
        stream.close()

    def _writer(self, partition: tuple[str, str]
                ) -> tuple[Any, pq.ParquetWriter, list[int]]:
        """The partition's open file, begun if it has none (its first, or its next)."""
        entry = self._writers.get(partition)
        if entry is None:
            files = self._files.setdefault(partition, [])
            name = self._name if not files else \
                f"{self._name.removesuffix('.parquet')}-{len(files) + 1}.parquet"
            relative = f"{partition_path(*partition)}/{name}"
            self._fs.makedirs(f"{self._folder}/{partition_path(*partition)}", exist_ok=True)
            stream = self._fs.open(f"{self._folder}/{relative}", "wb")
            files.append(relative)
            entry = self._writers[partition] = (
                stream, pq.ParquetWriter(stream, SCHEMA, **_PARQUET_OPTIONS), [0])
        return entry

    def close(self) -> list[str]:
        """Close the files; their paths relative to the folder (by partition, then in the
        order they were begun)."""
        for partition in list(self._writers):
            self._finish(partition)
        written = [path for _, files in sorted(self._files.items()) for path in files]
        self._files.clear()
        return written

    def abandon(self) -> None:
        """Close the files without finishing them (the caller removes the folder)."""
        for stream, writer, _ in self._writers.values():
            try:
                writer.close()
            finally:
                stream.close()
        self._writers.clear()


def int64_or_none(value: int | None) -> int | None:
    return value if value is None or -_INT64 <= value < _INT64 else None


def _detail_struct(details: list[Detail]) -> pa.StructArray:
    """Details as one struct array (one conversion, a field per column); a value int64
    cannot hold is null (rare: an SDO value of a generic node's domain)."""
    try:
        return pa.array(details, _DETAILS)
    except (OverflowError, pa.ArrowInvalid):
        return pa.array([d._replace(value=int64_or_none(d.value)) for d in details], _DETAILS)


def _partitions(models: list[str | None], dates: str | list[str]
                ) -> tuple[list[tuple[str, str]], np.ndarray[Any, np.dtype[np.signedinteger[Any]]]]:
    """The partitions of a segment's frames, in the order they first come, and each frame's
    (its index in them: 16-bit where they are few, which numpy sorts by radix)."""
    if isinstance(dates, str):  # one date: the model says which (a lookup per frame)
        found = {model: (model or UNKNOWN, dates) for model in dict.fromkeys(models)}
        partitions = list(dict.fromkeys(found.values()))
        index = {partition: n for n, partition in enumerate(partitions)}
        numbers = {model: index[partition] for model, partition in found.items()}
        keys: Iterable[Any] = models
        number: Callable[[Any], int] = numbers.__getitem__
    else:
        pairs = list(zip((model or UNKNOWN for model in models), dates, strict=True))
        partitions = list(dict.fromkeys(pairs))
        keys, number = pairs, {p: n for n, p in enumerate(partitions)}.__getitem__
    kind = np.int16 if len(partitions) <= np.iinfo(np.int16).max else np.int32
    return partitions, np.fromiter(map(number, keys), kind, len(models))
