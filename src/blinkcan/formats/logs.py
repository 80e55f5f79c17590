"""Frames from and to files: every log format python-can reads and writes (ASC, BLF, candump,
TRC, CSV, SQLite, MF4 with python-can's extra), and pcap with the SocketCAN link type.

Reading checks what a path is and reads text in lines of a bounded length (a stream, a
device, a file without newlines: formats/log_source.py), a ``.gz`` text log's too. A line of
a text log (candump, ASC, TRC, CSV) that is no frame, or is over the bound, is an
:class:`~blinkcan.formats.unreadable.UnreadableLine` in its place and reading goes on
(formats/candump.py, formats/text_logs.py).

Lossless: remote (RTR), error and CAN FD frames are read and written like data frames, each
whole (formats/log_writers.py mends python-can's writers where they change one; reading mends
what its readers misread: :func:`_as_written`). Where a target format cannot carry a kind of
frame (.trc: error frames) or a part of one (.csv: the channel, the CAN FD flags),
:class:`FrameWriter` counts and names what it did not write (formats/carried.py) instead of
losing it silently; a conversion with frames the target cannot hold is refused
(:meth:`FrameWriter.refusal`: nothing written). A conversion goes to a temporary file
beside the target, created exclusively under an unpredictable name, renamed over the target
when complete; a recording is written under its own name as it goes, valid up to its last
flush (:class:`FrameWriter`).
"""

from __future__ import annotations

import contextlib
import copy
import gzip
import io
import math
import os
import sqlite3
import struct
import tempfile
import zlib
from collections import Counter
from collections.abc import Iterator
from pathlib import Path
from types import TracebackType
from typing import TYPE_CHECKING, BinaryIO, Literal, TextIO, overload

from blinkcan.formats.candump import candump_messages, read_candump, read_candump_columns
from blinkcan.formats.candump_blocks import PlainBlocks
from blinkcan.formats.capture_file import WholeRecords, create_exclusively
from blinkcan.formats.columns import FrameColumns
from blinkcan.formats.compressed import COMPRESSIONS, open_decompressed
from blinkcan.formats.log_source import (
    DecompressedText,
    LineTooLongError,
    LogError,
    LogSource,
    log_source,
    open_binary,
    open_text,
)
from blinkcan.formats.unreadable import UnreadableLine, shown
from blinkcan.protocol.frame import Frame

if TYPE_CHECKING:  # python-can loads where a file needs it: a candump log reads without it
    import can

    from blinkcan.formats.pcap import PcapWriter

__all__ = ["FrameWriter", "LogError", "UnreadableLine", "describe_frame", "frame_kind",
           "read_frames", "read_log", "read_messages"]


def _read_errors() -> tuple[type[BaseException], ...]:
    """The errors python-can's readers raise on a file that is not what its name says (an
    ``except`` clause evaluates this only when an error came)."""
    import can  # noqa: PLC0415
    from can.io.blf import BLFParseError  # noqa: PLC0415

    return (ValueError, IndexError, KeyError, TypeError, struct.error, UnicodeDecodeError,
            sqlite3.Error,
            EOFError, can.CanError, NotImplementedError, ImportError, BLFParseError,
            gzip.BadGzipFile, zlib.error)


def is_pcap(path: Path) -> bool:
    """formats/pcap.py's ``is_pcap`` (python-can loads with it: where a file needs it)."""
    from blinkcan.formats import pcap  # noqa: PLC0415

    return pcap.is_pcap(path)


def frame_kind(message: can.Message) -> str:
    """"error", "remote", "fd" or "data"."""
    if message.is_error_frame:
        return "error"
    if message.is_remote_frame:
        return "remote"
    return "fd" if message.is_fd or len(message.data) > 8 else "data"


@overload
def read_messages(path: str | os.PathLike[str], unreadable: Literal[False] = False
                  ) -> Iterator[can.Message]: ...


@overload
def read_messages(path: str | os.PathLike[str], unreadable: Literal[True]
                  ) -> Iterator[can.Message | UnreadableLine]: ...


def read_messages(path: str | os.PathLike[str], unreadable: bool = False
                  ) -> Iterator[can.Message] | Iterator[can.Message | UnreadableLine]:
    """Every frame of a log file as python-can messages: data, remote, error, CAN FD. A
    line of a text log that is no frame is, with ``unreadable``, an :class:`UnreadableLine`
    in its place (reading goes on), else a :class:`LogError` naming it. The path is checked and
    text is read in bounded lines (formats/log_source.py)."""
    messages = _messages(log_source(path))
    return messages if unreadable else _strict(messages, path)


def _strict(messages: Iterator[can.Message | UnreadableLine], path: str | os.PathLike[str]
            ) -> Iterator[can.Message]:
    for message in messages:
        if isinstance(message, UnreadableLine):
            raise LogError(f"{path}: {message}")
        yield message


def _text_suffix(source: LogSource) -> str | None:
    """The text format a log is read in by lines (``.log.gz``: ``.log``), None for the
    others (binary, or read by python-can whole)."""
    suffix = _inner_suffix(source)
    if source.stream or suffix == ".log":  # a candump log reads without python-can
        return suffix
    from can.io.generic import TextIOMessageReader  # noqa: PLC0415
    from can.io.player import MESSAGE_READERS  # noqa: PLC0415

    reader_type = MESSAGE_READERS.get(suffix)
    if reader_type is not None and issubclass(reader_type, TextIOMessageReader):
        return suffix
    return None


def _inner_suffix(source: LogSource) -> str:
    """The format a log is in: ``.asc`` for ``x.asc``, ``x.asc.gz`` and ``x.asc.zst``."""
    if source.suffix in COMPRESSIONS:
        return Path(source.path.stem).suffix.lower()
    return source.suffix


@contextlib.contextmanager
def _open_bytes(source: LogSource) -> Iterator[BinaryIO]:
    """A binary log's bytes, a compressed one's decompressed as they are read."""
    if source.suffix not in COMPRESSIONS:
        with open_binary(source) as stream:
            yield stream
        return
    with open_decompressed(source.path, source.suffix) as decompressed:
        yield decompressed  # type: ignore[misc]  # a BufferedIOBase reads as a BinaryIO


def _messages(source: LogSource) -> Iterator[can.Message | UnreadableLine]:
    import can  # noqa: PLC0415

    from blinkcan.formats.pcap import PcapError, pcap_items  # noqa: PLC0415

    suffix = _inner_suffix(source)
    if is_pcap(source.path) or suffix in (".pcap", ".cap"):
        with _open_bytes(source) as stream:
            try:
                yield from pcap_items(stream)
            except PcapError as error:
                raise LogError(f"{source}: {error}") from None
            except EOFError as error:  # a compressed capture cut short
                raise LogError(f"{source}: {_reason(error)}") from None
        return
    text_suffix = _text_suffix(source)
    if text_suffix is not None:
        yield from _text_messages(source, text_suffix)
        return
    if source.suffix == ".zst" and suffix != ".blf":  # SQLite, asammdf: a file of their own
        raise LogError(f"{source}: a {suffix or 'log'} file is not read compressed "
                       f"(decompress it first: zstd -d {source.path})")
    try:
        if suffix == ".blf":  # python-can's reader reads it front to back: any stream
            blf = open_decompressed(source.path, source.suffix) \
                if source.suffix in COMPRESSIONS else source.path
            reader = _blf_reader()(blf)  # type: ignore[arg-type]  # BLFReader takes a stream
        else:
            reader = can.LogReader(str(source.path))
    except _read_errors() as error:
        raise LogError(f"{source}: not a readable log ({_reason(error)})") from None
    with reader:
        try:
            if suffix == ".blf":
                yield from _framed(_blf_messages(reader), "object")
                return
            yield from _framed((_as_written(message, suffix) for message in reader),
                               "row" if suffix == ".db" else "message")
        except _read_errors() as error:
            raise LogError(f"{source}: not a readable log ({_reason(error)})") from None


def _framed(messages: Iterator[can.Message | UnreadableLine], unit: str
            ) -> Iterator[can.Message | UnreadableLine]:
    """``messages`` of a log python-can reads whole (BLF, SQLite, MF4), each one that is no
    frame (formats/frame_check.py: a SQLite row's NaN time or 48-bit identifier) an
    :class:`UnreadableLine` in its place, numbered in ``unit``s from 1."""
    from blinkcan.formats.frame_check import why_no_frame  # noqa: PLC0415

    number = 0
    for message in messages:
        if isinstance(message, UnreadableLine):
            yield message
            continue
        number += 1
        if (why := why_no_frame(message)) is None:
            yield message
        else:
            text = (f"{message.timestamp!r} {message.arbitration_id!r} "
                    f"{bytes(message.data).hex().upper()}")  # python-can's str() may fail
            yield UnreadableLine(number, text, f"{shown(text)} is no frame ({why})",
                                 unit=unit)


def _blf_reader() -> type[can.io.generic.MessageReader]:
    from can.io.blf import BLFReader  # noqa: PLC0415

    class _BlfReader(BLFReader):
        """python-can's BLF reader, which can start again after a container it lost
        (``resync``): at the first object that starts in the next one."""

        resync = False

        def _parse_container(self, data: bytes) -> Iterator[can.Message]:
            if self.resync:  # the object split across the two is lost
                self.resync = False
                self._tail = b""
                start = data.find(b"LOBJ")
                data = data[start:] if start >= 0 else b""
            yield from super()._parse_container(data)

    return _BlfReader


def _blf_messages(reader: can.io.generic.MessageReader
                  ) -> Iterator[can.Message | UnreadableLine]:
    """A BLF log's messages; a log container whose data is corrupt (zlib's error, or an
    object in it that is none) costs its own frames only (issue 23), an
    :class:`UnreadableLine` (``unit`` "byte": where the next container starts) in their
    place. python-can's reader has read the whole container when it fails, so a copy of it
    reads on from the next one (an object split across the two is lost with it). A second
    error before a frame is read again (an object header that is none: the containers after
    it cannot be found) ends the reading. A log none of whose containers can be read is no
    BLF log."""
    from can.io.blf import BLFParseError, BLFReader  # noqa: PLC0415

    assert isinstance(reader, BLFReader)  # _blf_reader's
    messages = iter(reader)
    frames = 0
    corrupt: list[UnreadableLine] = []  # since the last frame read
    while True:
        try:
            message = next(messages, None)
        except (zlib.error, BLFParseError) as error:
            if corrupt:
                message = None  # found nothing after the last: the rest cannot be framed
            else:
                corrupt.append(UnreadableLine(
                    reader.file.tell(), "", "the log container before this byte is corrupt "
                    f"({_reason(error)}): its frames are lost", unit="byte"))
                reader = copy.copy(reader)
                reader.resync = True  # type: ignore[attr-defined]  # _blf_reader's
                messages = iter(reader)
                continue
        if message is None:
            if corrupt and not frames:
                raise LogError(f"{corrupt[0]}") from None
            yield from corrupt
            return
        if corrupt:
            yield from corrupt
            corrupt.clear()
        frames += 1
        yield _as_written(message, ".blf")


@contextlib.contextmanager
def _open_text(source: LogSource, encoding: str | None, errors: str | None = None
               ) -> Iterator[TextIO]:
    """A text log's stream, a ``.gz`` or ``.zst`` one decompressed as it is read."""
    if source.suffix not in COMPRESSIONS:
        with open_text(source, encoding, errors) as stream:
            yield stream
        return
    # a file cut short keeps every line before the cut (formats/log_source.py)
    with DecompressedText(open_decompressed(source.path, source.suffix), encoding or "utf-8",
                          errors or "strict") as compressed:
        yield compressed


def _text_messages(source: LogSource, suffix: str) -> Iterator[can.Message | UnreadableLine]:
    """A text log's messages from python-can's reader of its format (``suffix``), fed bounded
    lines, read on past a line it cannot read (formats/text_logs.py); a candump log's through
    formats/candump.py."""
    from blinkcan.formats.text_logs import text_log_messages  # noqa: PLC0415

    candump = suffix == ".log"
    with _open_text(source, "utf-8" if candump else None,
                    "surrogateescape" if candump else None) as stream:
        try:
            if candump:
                yield from candump_messages(stream)
                return
            yield from text_log_messages(stream, suffix,
                                         lambda message: _as_written(message, suffix))
        except LineTooLongError as error:
            raise LogError(f"{source}: {error}") from None
        except _read_errors() as error:
            raise LogError(f"{source}: not a readable log ({_reason(error)})") from None


def _as_written(message: can.Message, suffix: str) -> can.Message:
    """The frame the file holds, where python-can's reader reads it otherwise."""
    if len(message.data) > 8:  # .csv, .db: no FD flag, but only CAN FD carries over 8 bytes
        message.is_fd = True
    if message.is_fd and message.is_remote_frame:  # .asc: a 0-byte CAN FD frame reads as
        message.is_remote_frame = False  # remote; CAN FD has no remote frames (ISO 11898-1)
        message.dlc = 0
    if suffix == ".trc" and isinstance(message.channel, int):  # TRC numbers buses from 1:
        message.channel -= 1  # python-can's writer adds 1, its reader takes it as it is
    return message


def read_log(path: str | os.PathLike[str]
             ) -> Iterator[tuple[float, Frame | can.Message | UnreadableLine]]:
    """(timestamp, frame) pairs: a :class:`Frame` for each classic data frame, the
    ``can.Message`` for a remote, error or CAN FD frame, an :class:`UnreadableLine` for a
    line of a text log that is no frame (its timestamp NaN where it has none: its ``time`` says).
    candump logs (``.gz`` too) take a fast path."""
    source = log_source(path)
    if _text_suffix(source) == ".log":
        with _open_text(source, "utf-8", "surrogateescape") as stream:
            try:
                yield from read_candump(stream)
            except LineTooLongError as error:
                raise LogError(f"{source}: {error}") from None
            except _read_errors() as error:
                raise LogError(f"{source}: not a readable log ({_reason(error)})") from None
        return
    trusted = Frame.trusted  # python-can (or our pcap reader) parsed and checked the frames
    for message in _messages(source):
        if isinstance(message, UnreadableLine):
            yield math.nan if message.time is None else message.time, message
        elif frame_kind(message) == "data":
            yield message.timestamp, trusted(message.arbitration_id, bytes(message.data),
                                             message.is_extended_id)
        else:
            yield message.timestamp, message


#: items of a log that is not candump per block of :func:`read_log_columns`
_BLOCK_ITEMS = 1024


def read_log_columns(path: str | os.PathLike[str]) -> Iterator[FrameColumns]:
    """:func:`read_log` a block at a time, as columns (for a writer with no call per
    frame): a candump log's blocks of plain data frames read whole
    (formats/candump_blocks.py); a frame that is not a classic data frame, or a line that is
    no frame, is in the block's ``others`` in its place, its time in ``times`` as
    :func:`read_log` gives it."""
    source = log_source(path)
    if _text_suffix(source) == ".log":
        return _candump_columns(source)
    return _as_columns(read_log(path))


def _candump_columns(source: LogSource) -> Iterator[FrameColumns]:
    with _open_text(source, "utf-8", "surrogateescape") as stream:
        try:
            yield from read_candump_columns(stream, PlainBlocks())
        except LineTooLongError as error:
            raise LogError(f"{source}: {error}") from None
        except _read_errors() as error:
            raise LogError(f"{source}: not a readable log ({_reason(error)})") from None


def _as_columns(items: Iterator[tuple[float, Frame | can.Message | UnreadableLine]]
                ) -> Iterator[FrameColumns]:
    columns = FrameColumns()
    for timestamp, item in items:
        if isinstance(item, Frame):
            columns.add_frame(timestamp, None, item.can_id, item.extended, item.data)
        elif isinstance(item, UnreadableLine):
            columns.add_unreadable(item)
        else:
            columns.add_other(item, None)
        if len(columns) >= _BLOCK_ITEMS:
            yield columns
            columns = FrameColumns()
    if columns.times:
        yield columns


def read_frames(path: str | os.PathLike[str]) -> Iterator[tuple[float, Frame]]:
    """(timestamp, frame) pairs of the classic data frames of a log file; a line that is no
    frame raises :class:`LogError` naming it (nothing is skipped unsaid)."""
    for timestamp, item in read_log(path):
        if isinstance(item, Frame):
            yield timestamp, item
        elif isinstance(item, UnreadableLine):
            raise LogError(f"{path}: {item}")


def _reason(error: BaseException) -> str:
    text = str(error).splitlines()[0] if str(error) else type(error).__name__
    if isinstance(error, (NotImplementedError, ImportError)) and "asammdf" in text:
        return "MF4 needs asammdf: pip install 'python-can[mf4]'"
    return text


def describe_frame(message: can.Message) -> str:
    """"remote frame 70Ch", "error frame", "CAN FD frame 123h" for messages."""
    kind = frame_kind(message)
    if kind == "error":
        return "error frame"
    ident = f"{message.arbitration_id:08X}h" if message.is_extended_id else \
        f"{message.arbitration_id:03X}h"
    return f"{'CAN FD' if kind == 'fd' else kind} frame {ident}"


#: formats a recording may be written in: each is valid up to its last flush when the recorder
#: is killed (MF4 is written only when it is closed, so a killed recorder would leave nothing)
RECORDABLE = (".pcap", ".cap", ".log", ".asc", ".blf", ".csv", ".trc", ".db")


def _writer_class(suffix: str) -> type[can.io.generic.MessageWriter]:
    from blinkcan.formats.log_writers import WRITERS  # noqa: PLC0415

    try:
        return WRITERS[suffix]  # type: ignore[no-any-return]
    except KeyError:
        raise LogError(f"no write support for {suffix or 'a file without a suffix'} "
                       f"(pcap, or {' '.join(sorted(WRITERS))})") from None


def _check_target(path: Path, replace: bool, live: bool) -> None:
    """Refuse what cannot be written before anything is created."""
    suffix = path.suffix.lower()
    if live and suffix not in RECORDABLE:
        why = (".mf4 is written only when it is closed, so a killed recorder would leave "
               "nothing" if suffix == ".mf4" else "not a capture format")
        raise LogError(f"cannot record to {path.name}: {why}; record to one of "
                       f"{' '.join(RECORDABLE)} and convert it")
    if not is_pcap(path):
        _writer_class(suffix)
    if (path.is_symlink() or path.exists()) and not replace:
        raise LogError(f"{path} exists; pass --force to replace it")


class FrameWriter:
    """Write frames to ``path`` in the format its name says (.pcap, or python-can's formats).

    A conversion (the default) is atomic: frames go to a temporary file of the same suffix
    beside the target, created exclusively under an unpredictable name, renamed over the target
    by :meth:`close`; a failure leaves the target as it was. A recording (``live``) is written
    under its own name from the start, as ``tcpdump -w`` does, handed to the disk in whole
    frames at each :meth:`flush` (and at least every :attr:`FLUSH_EVERY` frames), so a killed
    recorder leaves a file valid up to its last flush; whatever ends it keeps what it wrote.
    Either way an existing file (a symlink included, never followed) is refused unless
    ``replace`` is set. ``count`` says how many frames were written, ``skipped`` what the format
    cannot carry (kind -> how many), ``skipped_names`` the first few of them."""

    SKIPPED_NAMED = 5
    FLUSH_EVERY = 1000

    def __init__(self, path: str | os.PathLike[str], replace: bool = False,
                 live: bool = False) -> None:
        self.path = Path(path)
        self.live = live
        suffix = self.path.suffix.lower()
        _check_target(self.path, replace, live)
        from blinkcan.formats.carried import CARRIES, Losses, writable_name  # noqa: PLC0415
        from blinkcan.runtime.canbus import to_message  # noqa: PLC0415

        self._to_message = to_message
        self._writable_name = writable_name
        self._pcap: PcapWriter | None = None
        self._file: WholeRecords | None = None
        self._logger: can.io.generic.MessageWriter | None = None
        carries = CARRIES.get(suffix)
        self._cannot = carries.dropped if carries is not None else frozenset()
        self.losses = Losses(suffix)
        self._numbered = self.losses.carries.channel == "number"
        self._named = self.losses.carries.channel == "name"
        self._unflushed = 0
        self.count = 0
        self.skipped: Counter[str] = Counter()
        self.skipped_names: list[str] = []
        if live:
            try:
                handle = create_exclusively(self.path, replace)
            except FileExistsError:
                raise LogError(f"{self.path} exists; pass --force to replace it") from None
            self._written = self.path
        else:
            handle, partial = tempfile.mkstemp(prefix=f".{self.path.name}.",
                                               suffix=self.path.suffix,
                                               dir=self.path.parent or ".")
            self._written = Path(partial)
            os.chmod(partial, 0o644)  # mkstemp makes 0600; a capture is shared like any file
        try:
            self._open(handle, suffix)
            if live:
                self.flush()  # the header: a recorder killed before its first frame leaves a
                # valid, empty capture
        except (ValueError, NotImplementedError, ImportError) as error:
            self._abandon()
            raise LogError(f"{self.path}: {_reason(error)}") from None
        except BaseException:
            self._abandon()
            raise

    def _open(self, handle: int, suffix: str) -> None:
        """The format's writer on the open file ``handle``."""
        if is_pcap(self.path):
            from blinkcan.formats.pcap import PcapWriter  # noqa: PLC0415

            self._file = WholeRecords(handle, str(self.path))
            self._pcap = PcapWriter(self._file)  # type: ignore[arg-type]
        elif suffix in (".db", ".mf4"):  # python-can's writer (or asammdf) opens it by name
            os.close(handle)
            self._logger = _writer_class(suffix)(self._written)
        else:
            self._file = WholeRecords(handle, str(self.path))
            stream = self._file if suffix == ".blf" else io.TextIOWrapper(
                self._file, encoding="utf-8", write_through=True)
            self._logger = _writer_class(suffix)(stream)  # type: ignore[arg-type]

    def _abandon(self) -> None:
        """The writer could not be set up: close the file and remove it (nothing was in it)."""
        if self._file is not None:
            self._file.close()
        self._written.unlink(missing_ok=True)

    def write(self, timestamp: float, frame: Frame) -> None:
        """Write one data frame."""
        self.write_message(self._to_message(frame, timestamp))

    def write_message(self, message: can.Message) -> None:
        """Write any frame (data, remote, error, CAN FD), or count it as skipped where the
        format cannot carry it."""
        kind = frame_kind(message)
        if kind in self._cannot:
            self.skipped[kind] += 1
            if len(self.skipped_names) < self.SKIPPED_NAMED:
                self.skipped_names.append(describe_frame(message))
            return
        self.count += 1
        self.losses.count(message, describe_frame)
        if self._numbered and message.channel is not None:
            # canN as N; any other name on the default channel (python-can's writers took
            # a name's trailing digits: bench-12345678 as channel 12345678, past BLF's 16
            # bits), as the losses said
            message.channel = self.losses.number(message.channel)
        elif self._named and message.channel is not None:
            # a name a line cannot hold as it is (a newline, a dict) on the default channel,
            # as the losses said: never its raw text
            message.channel = self._writable_name(message.channel)
        if self._pcap is not None:
            from blinkcan.formats.pcap import PcapError  # noqa: PLC0415

            try:
                self._pcap.write(message)
            except PcapError as error:  # a time before 1970: not written, the others kept
                self.count -= 1
                raise LogError(f"{self.path}: {error}") from None
        else:
            assert self._logger is not None
            self._logger.on_message_received(message)
        self._unflushed += 1
        if self._unflushed >= self.FLUSH_EVERY:
            self.flush()

    def flush(self) -> None:
        """Hand what was written so far to the file in whole frames: a recording killed after
        this keeps every frame written before it (.db: its rows committed). BLF's frames wait
        in a container python-can compresses when full: a recording closes the container and
        rewrites the file's header (its start time and counts) at each flush."""
        self._unflushed = 0
        from blinkcan.formats.log_writers import SqliteLogWriter  # noqa: PLC0415

        if self.live and isinstance(self._logger, SqliteLogWriter):  # .db: rows committed
            self._logger.commit()
        if self._file is None:
            return
        from can.io.blf import BLFWriter  # noqa: PLC0415

        if self.live and isinstance(self._logger, BLFWriter):
            blf = self._logger
            blf._flush()  # python-can's BLFWriter.stop() does these two steps
            end = self._file.tell()
            self._file.seek(0)
            blf._write_header(end)
            self._file.seek(end)
        self._file.flush()

    def skipped_text(self) -> str | None:
        """"2 frames .trc cannot carry were not written: 1 remote, 1 error (remote frame
        70Ch, error frame)", or None."""
        total = sum(self.skipped.values())
        if not total:
            return None
        kinds = ", ".join(f"{n} {kind}" for kind, n in sorted(self.skipped.items()))
        more = ", ..." if total > len(self.skipped_names) else ""
        return (f"{total} frame{'s' if total != 1 else ''} {self.path.suffix} cannot carry "
                f"{'were' if total != 1 else 'was'} not written: {kinds} "
                f"({', '.join(self.skipped_names)}{more})")

    def refusal(self, source: object) -> LogError:
        """A conversion that met frames the target cannot carry (:attr:`skipped`): the error
        that refuses it, naming how many of which kind and the formats that hold them."""
        from blinkcan.formats.carried import CARRIES  # noqa: PLC0415

        total = sum(self.skipped.values())
        kinds = ", ".join(f"{n} {kind}" for kind, n in sorted(self.skipped.items()))
        more = ", ..." if total > len(self.skipped_names) else ""
        holding = " ".join(sorted(suffix for suffix, carries in CARRIES.items()
                                  if not carries.dropped & self.skipped.keys()))
        return LogError(f"{source} holds {total} frame{'s' if total != 1 else ''} "
                        f"{self.path.suffix} cannot carry ({kinds}: "
                        f"{', '.join(self.skipped_names)}{more}): nothing written to "
                        f"{self.path}; these formats hold them: {holding}")

    def lost_lines(self) -> list[str]:
        """What the written frames lost, one line each ("3 frames lost their channel (can0,
        can1): .csv has no channel"); empty when the format kept everything."""
        return self.losses.lines()

    def _finish(self) -> None:
        if self._logger is not None:
            self._logger.stop()  # closes the text wrapper and so the file
        if self._file is not None:
            self._file.close()

    def close(self) -> None:
        """Finish the file; a conversion's then takes the target's place. A conversion whose
        last write fails (a full disk while .db commits its last rows) leaves the target as it
        was and no temporary file behind, as any other failure does."""
        if self.live:
            self._finish()
            return
        try:
            self._finish()
        except BaseException:
            self._discard()
            raise
        os.replace(self._written, self.path)

    def _discard(self) -> None:
        """Remove a failed conversion's temporary file (and SQLite's journal beside it)."""
        for leftover in (self._written, Path(f"{self._written}-journal")):
            leftover.unlink(missing_ok=True)

    def __enter__(self) -> FrameWriter:
        return self

    def __exit__(self, kind: type[BaseException] | None, error: BaseException | None,
                 trace: TracebackType | None) -> None:
        if error is None or self.live:  # a recording keeps what it wrote, whatever ended it
            self.close()
            return
        # the conversion failed: leave the target as it was, and no partial file behind
        try:
            self._finish()
        finally:
            self._discard()
