"""Opening a user's log: what its path is, and its lines with a bounded length.

Nothing in a log is trusted, not even what its path names:

- A regular file is read as its name says. ``-`` (standard input), a FIFO or a character
  device is read as a stream, front to back and once, in the format its name says, else as
  the candump log ``candump -L can0`` pipes out (``candump -L can0 | blinkcan decode -``); a
  stream cannot be a format that needs to seek (.blf, .db, .mf4, compressed). A directory, a
  block device or a socket is refused naming what it is; a path that is not there says so
  (a dangling symlink names its missing target).
- A text log is read in chunks and split into lines of at most :data:`MAX_LINE` bytes. A
  longer first line (a binary file, ``/dev/zero``, gigabytes without a newline) ends the
  reading with ``line 1 is over MAX_LINE bytes: not a FORMAT log``, so an endless stream of
  zeros ends within one line. A longer later line (a corrupt stretch of a capture) is one
  unreadable line (:class:`OverlongLine`: its first MAX_LINE characters are kept, the rest
  read past) and reading goes on at its newline: nothing after it is lost (issue 23).
  Memory stays bounded by one chunk whatever the file holds.
"""

from __future__ import annotations

import contextlib
import io
import os
import stat
import sys
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import BinaryIO, TextIO

from blinkcan.errors import BlinkcanError
from blinkcan.formats.unreadable import shown

#: the longest line of a text log: a CAN FD candump line is under 200 bytes, an ASC one 400
MAX_LINE = 4096
_CHUNK = 1 << 16
#: what a line-length error calls a format's log
_KIND = {".log": "candump", ".asc": "ASC", ".trc": "TRC", ".csv": "CSV"}
#: formats read front to back, which a stream can carry
STREAMABLE = frozenset({".log", ".asc", ".trc", ".csv", ".pcap", ".cap"})
_REFUSED = ((stat.S_ISDIR, "a directory"), (stat.S_ISBLK, "a block device"),
            (stat.S_ISSOCK, "a socket"))


class LogError(BlinkcanError, ValueError):
    """A file that cannot be read or written as a CAN log."""


class LineTooLongError(BlinkcanError, ValueError):
    """A line of a text log over :data:`MAX_LINE` bytes; the message says which."""


class UnterminatedLine(list[str]):
    """The block :func:`bounded_line_blocks` ends with when the file's last line has no
    newline after it: a line a reader cannot read there was cut off (a logger killed
    mid-write). ``cut_short``: a compressed file ended before its compressed stream did (a
    copy interrupted), so this line, whole or not, may have been cut; its text may be ""."""

    cut_short = False


class _EndsWhereCut(io.RawIOBase):
    """A decompressing stream's bytes up to where its compressed file ends: the decompressor's
    EOFError there (a file cut short) becomes the end of the data, and :attr:`cut_short` says
    so. Read a chunk at a time (``read1``), so every byte decompressed before the cut is
    delivered (a text reader's larger read would lose them with the error)."""

    def __init__(self, source: io.BufferedIOBase) -> None:
        super().__init__()
        self._source = source
        self.cut_short = False

    def readable(self) -> bool:
        return True

    def readinto(self, buffer: bytearray | memoryview) -> int:  # type: ignore[override]
        if self.cut_short:
            return 0
        try:
            data = self._source.read1(len(buffer))
        except EOFError:
            self.cut_short = True
            return 0
        size = len(data)
        buffer[:size] = data
        return size

    def close(self) -> None:
        self._source.close()
        super().close()


class DecompressedText(io.TextIOWrapper):
    """The text of a compressed log; :attr:`cut_short` once its end is read: the compressed
    file ended inside its compressed stream (:class:`_EndsWhereCut`)."""

    def __init__(self, source: io.BufferedIOBase, encoding: str, errors: str) -> None:
        self._ends = _EndsWhereCut(source)
        super().__init__(io.BufferedReader(self._ends), encoding=encoding, errors=errors)

    @property
    def cut_short(self) -> bool:
        return self._ends.cut_short


class OverlongLine(list[str]):
    """A block of :func:`bounded_line_blocks` that is one line over :data:`MAX_LINE`: its
    first MAX_LINE characters (a reader names it unreadable), ``length`` how long it is,
    ``unterminated`` when the file ends inside it."""

    length = 0
    unterminated = False

    @classmethod
    def of(cls, line: str, length: int) -> OverlongLine:
        overlong = cls([line[:MAX_LINE]])
        overlong.length = length
        return overlong

    def reason(self) -> str:
        """"'(1.0) can0 715#0000...' is 9,000 characters long, over MAX_LINE: no line"."""
        return (f"{shown(self[0])} is {self.length:,} characters long, over the "
                f"{MAX_LINE} a line of a log may have")


class NonAsciiLines(list[str]):
    """A block of :func:`bounded_line_blocks` with a character that is not ASCII: text read
    with ``errors="surrogateescape"`` holds each byte that is not UTF-8 as a surrogate there
    (an ASCII block cannot: a reader checks only these)."""


@dataclass(frozen=True)
class LogSource:
    """A log path checked: ``suffix`` is the format it is read in (by its name; ``.log``,
    candump, for a stream whose name says none), ``stream`` whether it is read once as it
    comes (standard input, a FIFO, a character device)."""

    path: Path
    suffix: str
    stream: bool

    @property
    def kind(self) -> str:
        """"candump", "ASC", ...: what a line-length error says the file is not."""
        return kind_of(self.suffix)

    @property
    def stdin(self) -> bool:
        return str(self.path) == "-"

    def __str__(self) -> str:
        return "standard input" if self.stdin else str(self.path)


def kind_of(suffix: str) -> str:
    """What a log of ``suffix`` is called: ".log" is "candump", ".asc" "ASC", ..."""
    return _KIND.get(suffix, suffix)


def log_source(path: str | os.PathLike[str]) -> LogSource:
    """``path`` checked (see the module docstring); :class:`LogError` names what is wrong."""
    source = Path(path)
    suffix = source.suffix.lower()
    if str(path) == "-":
        return LogSource(source, ".log", stream=True)
    try:
        mode = source.stat().st_mode
    except FileNotFoundError:
        if source.is_symlink():
            raise LogError(f"no such file: {source} (a symlink to {os.readlink(source)}, "
                           "which is not there)") from None
        raise LogError(f"no such file: {source}") from None
    except OSError as error:
        raise LogError(f"cannot read {source}: {error.strerror}") from None
    if stat.S_ISREG(mode):
        return LogSource(source, suffix, stream=False)
    for test, what in _REFUSED:
        if test(mode):
            raise LogError(f"{source} is {what}, not a log file")
    kind = "a FIFO" if stat.S_ISFIFO(mode) else "a character device"
    if suffix in STREAMABLE:
        return LogSource(source, suffix, stream=True)
    if suffix in (".blf", ".db", ".mf4", ".gz", ".zst"):
        raise LogError(f"{source} is {kind}: a {suffix} log is read from a regular file only "
                       "(streams carry candump, .asc, .trc, .csv and .pcap)")
    return LogSource(source, ".log", stream=True)


@contextlib.contextmanager
def open_text(source: LogSource, encoding: str | None = None,
              errors: str | None = None) -> Iterator[TextIO]:
    """The source as text (``encoding`` None: the locale's, as python-can reads; ``errors``
    as :func:`open` takes it, standard input included)."""
    if source.stdin:
        if errors is None:
            yield sys.stdin
            return
        stdin = io.TextIOWrapper(sys.stdin.buffer, encoding=encoding, errors=errors)
        try:
            yield stdin
        finally:
            stdin.detach()  # standard input stays open for whoever reads it next
        return
    try:
        stream = source.path.open(encoding=encoding, errors=errors)
    except OSError as error:
        raise LogError(f"cannot read {source}: {error.strerror}") from None
    with stream:
        yield stream


@contextlib.contextmanager
def open_binary(source: LogSource) -> Iterator[BinaryIO]:
    if source.stdin:
        yield sys.stdin.buffer
        return
    try:
        stream = source.path.open("rb")
    except OSError as error:
        raise LogError(f"cannot read {source}: {error.strerror}") from None
    with stream:
        yield stream


def bounded_lines(stream: TextIO, kind: str) -> Iterator[str]:
    """The lines of ``stream`` (without their newline), each at most :data:`MAX_LINE` long;
    a longer first line raises :class:`LineTooLongError` ("not a ``kind`` log"), a longer
    later one comes as its bounded prefix (:class:`OverlongLine` says which)."""
    for lines in bounded_line_blocks(stream, kind):
        yield from lines


def bounded_line_blocks(stream: TextIO, kind: str, chunk_size: int = _CHUNK
                        ) -> Iterator[list[str]]:
    """:func:`bounded_lines` a chunk (``chunk_size`` characters) at a time: for loops that
    want no call per line. A line over :data:`MAX_LINE` after the first is a block of its
    own, an :class:`OverlongLine` holding its first MAX_LINE characters; the rest of it is
    read past, never kept."""
    read = stream.read
    rest = ""
    after = ""  # what followed a line over MAX_LINE in the chunk its newline was in
    number = 0  # lines yielded so far
    while True:
        if after:
            chunk, after = after, ""
        elif not (chunk := read(chunk_size)):
            break
        text = rest + chunk if rest else chunk
        lines = text.split("\n")
        if not text.isascii():  # O(1): a str knows whether it is ASCII
            lines = NonAsciiLines(lines)
        rest = lines.pop()
        if len(rest) > MAX_LINE or (lines and max(map(len, lines)) > MAX_LINE):
            yield from _with_overlong(lines, number, kind)
            number += len(lines)
            if len(rest) > MAX_LINE:  # read past it to its newline
                if not number:
                    raise LineTooLongError(_too_long(1, kind))
                overlong, after = _read_past(read, rest)
                rest = ""
                number += 1
                yield overlong
            continue
        number += len(lines)
        yield lines
    cut_short = isinstance(stream, DecompressedText) and stream.cut_short
    if rest or cut_short:
        last = UnterminatedLine([rest])
        last.cut_short = cut_short
        yield last


def _too_long(number: int, kind: str) -> str:
    article = "an" if kind[0] in "AEFHILMNORSX" else "a"  # as the name is spoken: an ASC log
    return f"line {number} is over {MAX_LINE} bytes: not {article} {kind} log"


def _with_overlong(lines: list[str], number: int, kind: str) -> Iterator[list[str]]:
    """``lines`` (after ``number`` lines) in blocks, each line over MAX_LINE an
    :class:`OverlongLine` of its own; the log's first line over MAX_LINE ends the reading."""
    start = 0
    for index, line in enumerate(lines):
        if len(line) > MAX_LINE:
            if not number + index:
                raise LineTooLongError(_too_long(1, kind))
            if index > start:
                yield type(lines)(lines[start:index])
            yield OverlongLine.of(line, len(line))
            start = index + 1
    if start < len(lines):
        yield type(lines)(lines[start:])


def _read_past(read: Callable[[int], str], start: str) -> tuple[OverlongLine, str]:
    """A line over MAX_LINE that starts with ``start`` and has no newline in it yet: read up to
    its newline keeping none of it but its prefix; (the line, what follows its newline)."""
    length = len(start)
    while chunk := read(_CHUNK):
        end = chunk.find("\n")
        if end >= 0:
            return OverlongLine.of(start, length + end), chunk[end + 1:]
        length += len(chunk)
    overlong = OverlongLine.of(start, length)
    overlong.unterminated = True
    return overlong, ""
