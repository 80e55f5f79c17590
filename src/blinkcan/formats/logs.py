"""Frames from and to files: every log format python-can reads and writes (ASC, BLF, candump,
TRC, CSV, SQLite, MF4 with python-can's extra), and pcap with the SocketCAN link type.

Lossless: remote (RTR) and error frames are read and written like data frames. Where a target
format cannot carry a kind of frame (python-can's TRC writer drops remote, error and CAN FD
frames), :class:`FrameWriter` counts and names what it did not write instead of losing it
silently. Writing goes to a temporary file beside the target, created exclusively under an
unpredictable name, renamed over the target when complete; pcap is streamed to it frame by frame.
"""

from __future__ import annotations

import os
import sqlite3
import struct
import tempfile
from collections import Counter
from collections.abc import Iterator
from pathlib import Path
from types import TracebackType
from typing import TYPE_CHECKING, BinaryIO

from blinkcan.formats.candump import read_candump, with_error_details
from blinkcan.protocol.frame import Frame

if TYPE_CHECKING:  # python-can loads where a file needs it: a candump log reads without it
    import can

    from blinkcan.formats.pcap import PcapWriter


class LogError(ValueError):
    """A file that cannot be read or written as a CAN log."""




def _read_errors() -> tuple[type[BaseException], ...]:
    """The errors python-can's readers raise on a file that is not what its name says (an
    ``except`` clause evaluates this only when an error came)."""
    import can  # noqa: PLC0415
    from can.io.blf import BLFParseError  # noqa: PLC0415

    return (ValueError, IndexError, KeyError, struct.error, UnicodeDecodeError, sqlite3.Error,
            EOFError, can.CanError, NotImplementedError, ImportError, BLFParseError)

#: kinds of frame a format's python-can writer drops (can/io/trc.py: TRCWriter)
_CANNOT_CARRY = {".trc": frozenset({"remote", "error", "fd"})}


def frame_kind(message: can.Message) -> str:
    """"error", "remote", "fd" or "data"."""
    if message.is_error_frame:
        return "error"
    if message.is_remote_frame:
        return "remote"
    return "fd" if message.is_fd or len(message.data) > 8 else "data"


def _source(path: str | os.PathLike[str]) -> Path:
    source = Path(path)
    if not source.is_file():
        raise LogError(f"no such file: {source}")
    return source


def read_messages(path: str | os.PathLike[str]) -> Iterator[can.Message]:
    """Every frame of a log file as python-can messages: data, remote, error, CAN FD."""
    import can  # noqa: PLC0415

    from blinkcan.formats.pcap import PcapError, is_pcap, read_pcap_messages  # noqa: PLC0415

    source = _source(path)
    if is_pcap(source):
        with source.open("rb") as stream:
            try:
                yield from read_pcap_messages(stream)
            except PcapError as error:
                raise LogError(f"{source}: {error}") from None
        return
    try:
        reader = can.LogReader(str(source))
    except _read_errors() as error:
        raise LogError(f"{source}: not a readable log ({_reason(error)})") from None
    with reader:
        try:
            if source.suffix.lower() == ".log":
                with source.open(encoding="utf-8") as lines:
                    yield from with_error_details(iter(reader), lines)
            else:
                yield from reader
        except _read_errors() as error:
            raise LogError(f"{source}: not a readable log ({_reason(error)})") from None


def read_log(path: str | os.PathLike[str]) -> Iterator[tuple[float, Frame | can.Message]]:
    """(timestamp, frame) pairs: a :class:`Frame` for each classic data frame, the
    ``can.Message`` for a remote, error or CAN FD frame. candump logs take a fast path."""
    source = _source(path)
    if source.suffix.lower() == ".log":
        with source.open(encoding="utf-8") as stream:
            try:
                yield from read_candump(stream)
            except _read_errors() as error:
                raise LogError(f"{source}: not a readable log ({_reason(error)})") from None
        return
    trusted = Frame.trusted  # python-can (or our pcap reader) parsed and checked the frames
    for message in read_messages(source):
        if frame_kind(message) == "data":
            yield message.timestamp, trusted(message.arbitration_id, bytes(message.data),
                                             message.is_extended_id)
        else:
            yield message.timestamp, message


def read_frames(path: str | os.PathLike[str]) -> Iterator[tuple[float, Frame]]:
    """(timestamp, frame) pairs of the classic data frames of a log file."""
    for timestamp, item in read_log(path):
        if isinstance(item, Frame):
            yield timestamp, item


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


class FrameWriter:
    """Write frames to ``path`` in the format its name says (.pcap, or python-can's formats).

    Atomic: frames go to a temporary file of the same suffix beside the target, created
    exclusively under an unpredictable name, renamed over the target by :meth:`close`; an
    existing file is refused unless ``replace`` is set. ``count`` says how many frames were
    written, ``skipped`` what the format cannot carry (kind -> how many), ``skipped_names`` the
    first few of them. ``keep``: a failure keeps what was written under ``path`` (a recording:
    nothing recorded is lost) instead of leaving the target as it was (a conversion)."""

    SKIPPED_NAMED = 5

    def __init__(self, path: str | os.PathLike[str], replace: bool = False,
                 keep: bool = False) -> None:
        self.path = Path(path)
        self.keep = keep
        if self.path.exists() and not replace:
            raise LogError(f"{self.path} exists; pass --force to replace it")
        handle, partial = tempfile.mkstemp(prefix=f".{self.path.name}.",
                                           suffix=self.path.suffix, dir=self.path.parent or ".")
        self._partial = Path(partial)
        self._pcap: PcapWriter | None = None
        self._stream: BinaryIO | None = None
        self._logger: can.Listener | None = None
        self._cannot = _CANNOT_CARRY.get(self.path.suffix.lower(), frozenset())
        self.count = 0
        self.skipped: Counter[str] = Counter()
        self.skipped_names: list[str] = []
        import can  # noqa: PLC0415

        from blinkcan.formats.pcap import PcapWriter, is_pcap  # noqa: PLC0415

        try:
            os.chmod(partial, 0o644)  # mkstemp makes 0600; a capture is shared like any file
            if is_pcap(self.path):
                self._stream = os.fdopen(handle, "wb")
                self._pcap = PcapWriter(self._stream)
            else:
                os.close(handle)
                self._logger = can.Logger(str(self._partial))
        except (ValueError, NotImplementedError, ImportError) as error:
            self._partial.unlink(missing_ok=True)
            raise LogError(f"{self.path}: {_reason(error)}") from None
        except BaseException:
            self._partial.unlink(missing_ok=True)
            raise

    def write(self, timestamp: float, frame: Frame) -> None:
        """Write one data frame."""
        from blinkcan.runtime.canbus import to_message  # noqa: PLC0415 (decode starts lighter)

        self.write_message(to_message(frame, timestamp))

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
        if self._pcap is not None:
            self._pcap.write(message)
        else:
            assert self._logger is not None
            self._logger.on_message_received(message)

    def flush(self) -> None:
        """Push what was written so far to the file (a recording survives a crash)."""
        if self._stream is not None:
            self._stream.flush()

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

    def _finish(self) -> None:
        if self._stream is not None:
            self._stream.flush()
            os.fsync(self._stream.fileno())
            self._stream.close()
        elif self._logger is not None:
            self._logger.stop()

    def close(self) -> None:
        self._finish()
        os.replace(self._partial, self.path)

    def __enter__(self) -> FrameWriter:
        return self

    def __exit__(self, kind: type[BaseException] | None, error: BaseException | None,
                 trace: TracebackType | None) -> None:
        if error is None or self.keep:
            self.close()
            return
        # the writing failed: leave the target as it was, and no partial file behind
        try:
            self._finish()
        finally:
            self._partial.unlink(missing_ok=True)
