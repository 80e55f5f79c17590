"""The table of the dataset: one row per decoded event (see ``rows.py``), and its layout.

``OUT/model=<model>/date=<YYYY-MM-DD>/<source key>.parquet`` (a long log's partition goes on
in ``<source key>-2.parquet``, ...: writer.GROUPS_PER_FILE): Hive partitions by the model of
the node a row is about (``unknown`` where no model is known: foreign frames) and by the UTC
date of its time; the partition columns are in the path, not in the files (Hive's way, which
DuckDB, Spark, Athena, pyarrow, pandas and polars read). ``_blinkcan/`` beside them holds the
manifests (one per source file) and the files being written; readers skip names starting
with ``_`` (pyarrow, Spark) and ``blinkcan query`` reads ``model=*/date=*/*.parquet`` only.
"""

from __future__ import annotations

import pyarrow as pa

ROWS_PER_GROUP = 65_536
UNKNOWN = "unknown"  # the partition of rows with no model, or no valid time



def _field(name: str, kind: pa.DataType, nullable: bool = True, doc: str = "") -> pa.Field:
    """A column with its meaning in the Parquet metadata (``doc``)."""
    return pa.field(name, kind, nullable, metadata={"doc": doc})


SCHEMA = pa.schema([
    _field("time", pa.timestamp("us", tz="UTC"), doc="when the frame was logged"),
    _field("source", pa.string(), nullable=False, doc="the log file, as an absolute path"),
    _field("channel", pa.string(), doc="the log's channel (can0, 1), null when it has none"),
    _field("can_id", pa.int32(), doc="11- or 29-bit identifier (null: an unreadable line)"),
    _field("extended", pa.bool_(), doc="29-bit identifier (null: an unreadable line)"),
    _field("node", pa.int16(), doc="CANopen node id or J1939 address the row is about"),
    _field("kind", pa.string(), nullable=False, doc="rows.KINDS"),
    _field("key", pa.int16(), doc="key number (key and led rows)"),
    _field("pin", pa.int16(), doc="output pin (output and fault rows)"),
    _field("state", pa.string(), doc="pressed/released, on/blink, high/off, fault/cleared, "
                                      "the NMT state, the SDO step, unchanged"),
    _field("colour", pa.string(), doc="LED colour (led rows)"),
    _field("value", pa.int64(), doc="a number the event carries (SDO value, level, ...; "
                                     "an unreadable line's line number)"),
    _field("text", pa.string(), nullable=False,
           doc="what blinkcan decode prints; an unreadable line's text as the log holds it"),
    _field("data", pa.binary(), doc="the frame's data bytes (null: an unreadable line)"),
])
PARTITIONS = ("model", "date")
