"""python-can's log writers, mended where they change a frame the format itself can hold.

- candump ``.log``: python-can writes every error frame as a bus error without data, a remote
  frame without its DLC, and moves a time earlier than the one before; can-utils' own lines
  keep all three (``20000004#0004000000000000``, ``70C#R3``: can-utils lib.c sprint_canframe).
- ``.asc``: the start date (``Begin Triggerblock``) carries milliseconds, and python-can counts
  the relative times from the first frame's exact time, so reading the absolute times back
  loses the rest of that millisecond; and a frame earlier than the first is written as an
  absolute time that reads back as a relative one. Here the times count from the first
  frame's millisecond, and an earlier frame takes that time (counted: formats/carried.py).
  The date's milliseconds have three digits (python-can writes 50 ms as ``.50``: 500 ms).
- ``.blf``: the header holds no date before 1990, yet python-can counts the times from the
  first frame: a log whose times start near 0 reads back shifted by its first time. Such a log
  counts from 0 here.
- ``.trc``: python-can's TRCWriter drops remote and CAN FD frames (a warning in its log, and
  nothing in the file), though TRC 2.1, the version it writes, has them: ``RR`` (remote, its
  DLC in the ``L`` column), ``FD`` and ``FB`` (CAN FD, FB with the bit rate switch, ``L`` the
  DLC code), all of which python-can's TRCReader reads. :class:`TrcWriter` writes them. The
  error state indicator is not written (formats/carried.py counts it): python-can's reader
  takes ``FE`` for BRS and ESI and ``BI`` for ESI alone, where PEAK's format has ``FE`` for
  ESI and ``BI`` for both, so either way one side would misread it. Error frames (TRC's
  ``ER``) are not written at all: python-can's reader skips ``ER`` lines, so a frame written
  so would be lost on reading; ``convert`` refuses them (cli/convert.py).
- ``.db``: python-can's SqliteWriter hands frames to a thread that, once stopped, ends after
  the batch it is writing and drops what is still queued (a 2,885-frame conversion kept 501).
  :class:`SqliteLogWriter` writes the same table (python-can's SqliteReader reads it)
  synchronously, in the caller's thread: nothing queued, every row committed by ``stop()``,
  and a recording's rows committed at each ``flush()``. SQLite's own errors (a full disk is
  ``disk I/O error``) are raised as ``OSError``, as every other writer's are.
"""

from __future__ import annotations

import os
import sqlite3
from collections.abc import Iterator
from contextlib import contextmanager
from datetime import datetime
from typing import Any

import can
from can.io.asc import ASCWriter
from can.io.blf import BLFWriter
from can.io.canutils import CanutilsLogWriter
from can.io.generic import MessageWriter
from can.io.logger import MESSAGE_WRITERS
from can.io.trc import TRCWriter
from can.util import channel2int, len2dlc

from blinkcan.formats.carried import (
    BLF_DATED_FROM,
    DEFAULT_CHANNEL,
    start_millisecond,
    writable_name,
)
from blinkcan.formats.pcap import CAN_EFF_MASK, CAN_ERR_FLAG, CANFD_BRS, CANFD_ESI


class CandumpWriter(CanutilsLogWriter):
    """candump ``-L`` lines as can-utils writes them (see the module docstring); a frame
    with no channel on :data:`~blinkcan.formats.carried.DEFAULT_CHANNEL` (python-can's
    default, ``vcan0``, named a channel no bus had), as is one whose name a line cannot hold
    as it is (formats/carried.py's writable_name: a newline would split the line)."""

    def __init__(self, file: Any, channel: str = DEFAULT_CHANNEL, append: bool = False
                 ) -> None:
        super().__init__(file, channel=channel, append=append)

    def on_message_received(self, msg: can.Message) -> None:
        channel = writable_name(msg.channel) or self.channel  # never a name's raw text
        stamp = f"({msg.timestamp:f}) {channel}"
        if msg.is_error_frame:  # linux/can/error.h: the class in the identifier, 8 data bytes
            ident = CAN_ERR_FLAG | (msg.arbitration_id & CAN_EFF_MASK)
            self.file.write(f"{stamp} {ident:08X}#{bytes(msg.data[:8]).hex().upper()}\n")
            return
        ident_text = f"{msg.arbitration_id:08X}" if msg.is_extended_id else \
            f"{msg.arbitration_id:03X}"
        if msg.is_remote_frame:
            body = f"R{msg.dlc:X}" if msg.dlc else "R"
        elif msg.is_fd:
            flags = (CANFD_BRS if msg.bitrate_switch else 0) | (
                CANFD_ESI if msg.error_state_indicator else 0)
            body = f"#{flags:X}{bytes(msg.data).hex().upper()}"
        else:
            body = bytes(msg.data).hex().upper()
        self.file.write(f"{stamp} {ident_text}#{body} {'R' if msg.is_rx else 'T'}\n")


class AscWriter(ASCWriter):
    """ASC whose absolute times read back as written (see the module docstring)."""

    def log_event(self, message: str, timestamp: float | None = None) -> None:
        if timestamp is not None:
            if not self.header_written:
                start = start_millisecond(timestamp)
                self.started = self.last_timestamp = start
                date = self._format_header_datetime(datetime.fromtimestamp(start))
                self.file.write(f"Begin Triggerblock {date}\n")
                self.header_written = True
                super().log_event("Start of measurement")
            timestamp = max(timestamp, self.started)
        super().log_event(message, timestamp)

    def _format_header_datetime(self, dt: datetime) -> str:
        """Three digits of milliseconds: python-can writes 50 ms as ``.50``, read back as
        500 ms, so every time of a log starting in a second's first 100 ms moved."""
        return dt.strftime(self.FORMAT_DATE.format(f"{dt.microsecond // 1000:03d}"))


class BlfWriter(BLFWriter):
    """BLF whose times near 0 read back as written (see the module docstring)."""

    def on_message_received(self, msg: can.Message) -> None:
        if self.start_timestamp is None and msg.timestamp < BLF_DATED_FROM:
            self.start_timestamp = 0.0
        super().on_message_received(msg)


class TrcWriter(TRCWriter):
    """TRC 2.1 with remote and CAN FD frames (see the module docstring)."""

    LINE = "{number:>7} {time:13.3f} {kind} {channel:>2} {ident:>8} {direction:>2} -  {dlc:<4} "

    def on_message_received(self, msg: can.Message) -> None:
        if msg.is_error_frame or not (msg.is_remote_frame or msg.is_fd):
            super().on_message_received(msg)  # data frames as python-can writes them
            return
        if self.first_timestamp is None:
            self.first_timestamp = msg.timestamp
        channel = channel2int(msg.channel)  # as python-can's writer numbers them, from 1
        channel = self.channel if channel is None else channel + 1
        if msg.is_remote_frame:
            kind, dlc, data = "RR", msg.dlc, ""
        else:
            kind = "FB" if msg.bitrate_switch else "FD"
            dlc, data = len2dlc(len(msg.data)), " ".join(f"{b:02X}" for b in msg.data)
        ident = f"{msg.arbitration_id:07X}" if msg.is_extended_id else \
            f"{msg.arbitration_id:04X}"
        line = self.LINE.format(number=self.msgnr, time=(msg.timestamp - self.first_timestamp)
                                * 1000, kind=kind, channel=channel, ident=ident,
                                direction="Rx" if msg.is_rx else "Tx", dlc=dlc)
        self.msgnr += 1
        self.log_event(line + data, msg.timestamp)


class SqliteLogWriter(MessageWriter):
    """python-can's SQLite table (``messages``: ts, arbitration_id, extended, remote, error,
    dlc, data), written in the caller's thread (see the module docstring)."""

    TABLE = "messages"
    #: rows handed to SQLite at once
    BATCH = 500

    def __init__(self, file: str | os.PathLike[str]) -> None:  # by name, as python-can's
        with _as_os_error():
            self._connection = sqlite3.connect(file)
            self._connection.execute(  # python-can's SqliteWriter._create_db
                f"CREATE TABLE IF NOT EXISTS {self.TABLE} (ts REAL, arbitration_id INTEGER, "
                "extended INTEGER, remote INTEGER, error INTEGER, dlc INTEGER, data BLOB)")
            self._connection.commit()
        self._pending: list[tuple[float, int, bool, bool, bool, int, bytes]] = []
        self.num_frames = 0

    def on_message_received(self, msg: can.Message) -> None:
        self._pending.append((msg.timestamp, msg.arbitration_id, msg.is_extended_id,
                              msg.is_remote_frame, msg.is_error_frame, msg.dlc,
                              bytes(msg.data)))
        if len(self._pending) >= self.BATCH:
            self._insert()

    def _insert(self) -> None:
        if self._pending:
            with _as_os_error():
                self._connection.executemany(
                    f"INSERT INTO {self.TABLE} VALUES (?, ?, ?, ?, ?, ?, ?)", self._pending)
            self.num_frames += len(self._pending)
            self._pending.clear()

    def commit(self) -> None:
        """Every row received so far into the file."""
        self._insert()
        with _as_os_error():
            self._connection.commit()

    def stop(self) -> None:
        try:
            self.commit()
        finally:
            self._connection.close()


@contextmanager
def _as_os_error() -> Iterator[None]:
    """An SQLite failure (``disk I/O error``, ``database or disk is full``) as the OSError
    every other writer raises, so the caller names the file it could not write."""
    try:
        yield
    except sqlite3.Error as error:
        raise OSError(str(error)) from error


#: the writer of each suffix: python-can's, mended as above
WRITERS: dict[str, Any] = {**MESSAGE_WRITERS, ".log": CandumpWriter, ".asc": AscWriter,
                           ".blf": BlfWriter, ".trc": TrcWriter, ".db": SqliteLogWriter}
