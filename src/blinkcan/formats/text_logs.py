"""ASC, TRC and CSV logs read by python-can's readers, on past a bad line (issue 23: nothing a
user recorded is lost).

python-can's text readers parse a line at a time from the file they are given, and a line
they cannot parse ends their iteration with its error: the rest of the file would be lost.
They are given the log's bounded lines (formats/log_source.py) through :class:`_Feed`, which
knows the line each one read last; when a reader raises, that line is an
:class:`~blinkcan.formats.unreadable.UnreadableLine` in its place and a copy of the reader (its
header's state kept: ASC's start date and base, TRC's version and columns) reads on from the
next line. The copy's iteration starts again with its header step, so it is handed one
``;`` line first, which each of them passes over (ASC: the line that ends its header; TRC: a
comment; CSV: its column names). python-can's ASC header step drops the line it ends on when
that is no header line (a frame, in a log with no "internal events logged" line):
:class:`_AscReader` hands it over again. A line over MAX_LINE, or the last of a compressed file cut
short, is never handed to a reader: it is unreadable as such, as in a candump log. TRC's
reader drops a line it cannot split into its columns with a logged warning;
:class:`_TrcReader` lets that error through, so the line is named like any other. ASC's
reader passes over a line it does not take for a frame (an event, a comment, a line cut
before its data): python-can's reading of the format, kept.
A log none of whose lines is a frame is not a log of that format: ValueError once it is read.
"""

from __future__ import annotations

import copy
import re
from collections.abc import Callable, Iterator
from typing import TYPE_CHECKING, TextIO

from blinkcan.formats.frame_check import why_no_frame
from blinkcan.formats.log_source import (
    OverlongLine,
    UnterminatedLine,
    bounded_line_blocks,
    kind_of,
)
from blinkcan.formats.unreadable import UnreadableLine, printable, shown

if TYPE_CHECKING:
    import can

#: what a python-can text reader raises on a line it cannot parse (float(), int(), unpacking,
#: a column that is not there, base64, a date out of range)
_LINE_ERRORS = (ValueError, IndexError, KeyError, TypeError, ArithmeticError)
#: handed to a reader that starts again: the line its header step passes over
_RESUME = ";"
#: the lines python-can's ASC header step takes (can/io/asc.py ASCReader._extract_header):
#: the start date, the number base, a comment, "(no) internal events logged"
_ASC_HEADER_LINE = re.compile(
    r"date\s+\w+\s+.|base\s+(?:hex|dec)|//|(?:no)?\s*internal\s+events\s+logged",
    re.IGNORECASE)


class _Feed:
    """The lines a reader reads, one at a time; ``last`` is the one it read last (its
    number: ``number``), ``passed`` the lines over MAX_LINE met on the way (never handed)."""

    def __init__(self, stream: TextIO, kind: str) -> None:
        self._blocks = bounded_line_blocks(stream, kind)
        self._lines: Iterator[str] = iter(())
        self._resume = False
        self._again: str | None = None
        self.kind = kind
        self.last = ""
        self.handed = ""  # what the reader was handed last: ``last``, or :data:`_RESUME`
        self.number = 0
        self.cut_off = False  # ``last`` is the file's last line, no newline after it
        self.passed: list[UnreadableLine] = []
        self.failed: BaseException | None = None  # the stream's own error (not a line's)

    def __iter__(self) -> _Feed:
        return self

    def __next__(self) -> str:
        if self._resume:
            self._resume = False
            self.handed = _RESUME
            return _RESUME
        if self._again is not None:
            self.handed, self._again = self._again, None
            return self.handed
        while True:
            for line in self._lines:
                self.number += 1
                self.last = self.handed = line
                return line
            block = self._next_block()
            self.cut_off = type(block) is UnterminatedLine
            self._lines = iter(block)

    def _next_block(self) -> list[str]:
        """The next block of lines a reader is handed (StopIteration at the end)."""
        try:
            block = next(self._blocks)
            while type(block) is OverlongLine or (
                    isinstance(block, UnterminatedLine) and block.cut_short):
                self.number += 1
                self.passed.append(self._not_handed(block))
                block = next(self._blocks)
        except StopIteration:
            raise
        except BaseException as error:
            self.failed = error
            raise
        return block

    def again(self) -> None:
        """Hand the line read last once more (its number unchanged)."""
        self._again = self.last

    def resume(self) -> None:
        """The next reader starts: hand it :data:`_RESUME` first."""
        self._resume = True

    def close(self) -> None:
        """python-can's readers close their file when done: the stream is the caller's."""

    def unreadable(self, error: BaseException) -> UnreadableLine:
        """The line read last, which ``error`` says is no frame of this format."""
        line = self.last
        why = str(error).splitlines()[0] if str(error) else type(error).__name__
        reason = f"{shown(line)} is not {_article(self.kind)} {self.kind} line ({why})"
        return UnreadableLine(self.number, printable(line), reason, None, self.cut_off)

    def _not_handed(self, block: list[str]) -> UnreadableLine:
        """A line no reader is handed: over MAX_LINE, or the last line of a compressed file
        cut short (it may have been cut, whole or not)."""
        if isinstance(block, OverlongLine):
            return UnreadableLine(self.number, printable(block[0]), block.reason(), None,
                                  block.unterminated)
        line = block[0]
        where = f"{shown(line)} is where" if line.strip() else "there"
        return UnreadableLine(self.number, printable(line), f"{where} the compressed file "
                              "ends, before its compressed stream does: cut short", None, True)


def _article(kind: str) -> str:
    return "an" if kind[:1] in "AEFHILMNORSX" else "a"


def _asc_reader() -> type[can.io.generic.MessageReader]:
    from can.io.asc import ASCReader  # noqa: PLC0415

    class _AscReader(ASCReader):
        """python-can's ASC reader whose header step keeps the line it ends on: python-can's
        ends at the first line that is no header line and drops that line, so a log with no
        "internal events logged" line before its frames lost its first frame with no word."""

        def _extract_header(self) -> None:
            feed = self.file
            super()._extract_header()
            if isinstance(feed, _Feed) and feed.handed is feed.last and \
                    not _ASC_HEADER_LINE.match(feed.last.strip()):
                feed.again()  # a frame, an event or a trigger block: the log's, read it

    return _AscReader


def _trc_reader() -> type[can.io.generic.MessageReader]:
    from can.io.trc import TRCReader  # noqa: PLC0415

    class _TrcReader(TRCReader):
        """python-can's TRC reader with a line it cannot split into its columns an error
        (python-can logs it and drops the line)."""

        def _parse_line(self, line: str) -> can.Message | None:
            return self._parse_cols(tuple(line.split(maxsplit=self._num_columns)))

    return _TrcReader


def text_log_messages(stream: TextIO, suffix: str,
                      as_written: Callable[[can.Message], can.Message] = lambda m: m
                      ) -> Iterator[can.Message | UnreadableLine]:
    """The messages python-can's reader of ``suffix`` (.asc, .trc, .csv) reads from
    ``stream``, each as ``as_written`` makes it; each line it cannot read, or reads as a
    message that is no frame (formats/frame_check.py: a 48-bit identifier, a time of inf, a
    DLC of 99 over one byte), an :class:`UnreadableLine` in its place."""
    from can.io.player import MESSAGE_READERS  # noqa: PLC0415

    feed = _Feed(stream, kind_of(suffix))
    reader_type = {".trc": _trc_reader, ".asc": _asc_reader}.get(
        suffix, lambda: MESSAGE_READERS[suffix])()
    # an ASC file's times count from its start date: absolute, as every other format's
    options = {"relative_timestamp": False} if suffix == ".asc" else {}
    reader = reader_type(feed, **options)  # type: ignore[arg-type]  # iterates it only
    messages = iter(reader)
    frames = 0
    failed_at = -1  # the number of the line a reader failed on last
    first: UnreadableLine | None = None
    while True:
        try:
            message = next(messages, None)
        except _LINE_ERRORS as error:
            if feed.failed is not None:
                raise  # the stream's (a byte that is not text, a first line over MAX_LINE)
            if feed.number == failed_at:  # no line read since the last: the resumed reader
                message = None  # read its ';' only (at the end, TRC parses its header's last)
            else:
                failed_at = feed.number
                feed.passed.append(feed.unreadable(error))
                reader = copy.copy(reader)  # its header's state, reading on from the next line
                feed.resume()
                messages = iter(reader)
                continue
        if feed.passed:
            first = first or feed.passed[0]
            yield from feed.passed
            feed.passed.clear()
        if message is None:
            break
        message = as_written(message)
        if (why := why_no_frame(message)) is not None:
            unreadable = feed.unreadable(ValueError(why))
            first = first or unreadable
            yield unreadable
            continue
        frames += 1
        yield message
    if first is not None and not frames:
        raise ValueError(f"no line is {_article(feed.kind)} {feed.kind} frame ({first})")
