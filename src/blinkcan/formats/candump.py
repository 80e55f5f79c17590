"""candump ``-L`` log lines (``(1700000000.000500) can0 715#05``) read straight into frames.

Why not python-can's ``CanutilsLogReader`` for every line: it builds a ``can.Message`` and
parses the data two hex digits at a time, about 4 us a frame, which is more than half of the
whole budget of ``blinkcan decode --json`` (DESIGN.md: 1.5x python-can + cantools + json). A
plain data-frame line is split once and its data read by ``bytes.fromhex``, about 1 us.

Every other line (remote frames ``R``, CAN FD ``##``, error-flag identifiers, odd digit counts,
anything unusual) is handed to python-can's own reader, one line at a time, so the result is
python-can's by construction, with one correction where python-can loses what the line says
(:func:`restore_error_details`: error frames); tests/formats/test_candump.py checks the fast
path against python-can's reader (plus that correction) on generated logs.

Lines are read with a bounded length (:func:`~blinkcan.formats.log_source.bounded_lines`): a
file without newlines is refused at its first line, never read whole; a later line over the
bound is an unreadable line like any other, its prefix kept. A line that is no frame
(bad digits, a byte that is not UTF-8, the half line of a capture cut off) is an
:class:`~blinkcan.formats.unreadable.UnreadableLine` in its place and reading goes on (issue
23); comments (``#``) and blank lines are skipped, as candump-style tools do.
"""

from __future__ import annotations

import contextlib
import io
import math
import re
from collections.abc import Iterator
from typing import TYPE_CHECKING, TextIO

from blinkcan.formats.candump_blocks import PlainBlocks
from blinkcan.formats.columns import FrameColumns
from blinkcan.formats.log_source import (
    LineTooLongError,
    OverlongLine,
    UnterminatedLine,
    bounded_line_blocks,
)
from blinkcan.formats.unreadable import UnreadableLine, printable, shown
from blinkcan.protocol.frame import Frame

if TYPE_CHECKING:  # python-can loads for the first unusual line (start-up: issue 22)
    from collections.abc import Callable

    import can

    #: reads a block of lines that are all plain frames whole (None: line by line here)
    BlockReader = Callable[[list[str]], FrameColumns | None]

_ERROR_FLAG = 0x20000000  # linux/can.h CAN_ERR_FLAG
_DIRECTIONS = frozenset({"R", "T", "r", "t"})
_NOT_DATA = frozenset({"#", "R", "r"})  # CAN FD, remote
_new_tuple = tuple.__new__  # Frame.trusted without the call: the ids and data are checked here


def _python_can(line: str) -> can.Message | None:
    """The message python-can reads from one line (None for a blank line); ValueError for
    what :func:`_checked` refuses."""
    from can.io.canutils import CanutilsLogReader  # noqa: PLC0415

    _checked(line.split(), line)
    reader = CanutilsLogReader(io.StringIO(line))
    message = next(iter(reader), None)
    return restore_error_details(message, line) if message is not None else None


def _checked(fields: list[str], line: str, suspect: bool = False) -> None:
    """Refuse a line python-can would misread (``fields``: its words): not whole (a capture
    cut off mid-line), an identifier over 8 digits, data of an odd number of hex digits; and
    where it may hold one (``suspect``: not ASCII), a byte that is not UTF-8."""
    if suspect and _escaped(line):
        raise ValueError(f"{shown(line)} is not UTF-8 text")
    if 0 < len(fields) < 3 or (len(fields) >= 3 and "#" not in fields[2]):
        # e.g. the last line of a capture cut off by a killed candump
        raise ValueError(_not_whole(line))
    if len(fields) < 3:
        return
    ident, _, body = fields[2].partition("#")
    if len(ident) > 8:
        # candump writes 3 hex digits (11-bit) or 8 (29-bit, with the error flag): python-can
        # would read the flag bits of a longer identifier and call the line an error frame
        raise ValueError(f"identifier {ident} has more than 8 hex digits")
    data = body[2:] if body[:1] == "#" else body  # CAN FD: '#', its flags digit, the data
    if data[:1] not in ("R", "r") and len(data) % 2:
        # can-utils' parse_canframe (lib.c) refuses a lone digit: python-can would read
        # '0102030' (a line cut inside its data) as 01 02 03 00
        raise ValueError(f"data {data} has an odd number of hex digits")


def _not_whole(line: str) -> str:
    return f"{shown(line)} is not a whole candump line ((TIME) CHANNEL ID#DATA)"


def restore_error_details(message: can.Message, line: str) -> can.Message:
    """A SocketCAN error frame as what it is. python-can's candump reader takes an identifier
    with CAN_ERR_FLAG for an error frame only when CAN_ERR_BUSERROR is set too, and then keeps
    its time and nothing else (no error class bits, no data: can/io/canutils.py); any other
    error class becomes a data frame. Every CAN_ERR_FLAG identifier is an error frame
    (linux/can/error.h), with its class bits and data."""
    if not (message.is_error_frame or message.is_extended_id):
        return message
    ident, _, data = line.split()[2].partition("#")
    can_id = int(ident, 16)
    if len(ident) == 8 and can_id & _ERROR_FLAG:
        message.is_error_frame, message.is_remote_frame, message.is_fd = True, False, False
        message.arbitration_id = can_id & 0x1FFFFFFF
        message.data = bytearray.fromhex(data[: 2 * 8])
        message.dlc = len(message.data)
    return message


def with_error_details(messages: Iterator[can.Message], lines: Iterator[str]
                       ) -> Iterator[can.Message]:
    """python-can's messages of a candump log, each error frame completed from its line
    (python-can reads one message per line that is not blank)."""
    text_lines = (line for line in lines if line.strip())
    for message, line in zip(messages, text_lines, strict=True):
        yield restore_error_details(message, line)


def candump_messages(stream: TextIO) -> Iterator[can.Message | UnreadableLine]:
    """python-can's messages of a candump log, each error frame completed from its line, the
    lines bounded, in one pass (a stream is read once); a line that is not a frame is an
    :class:`UnreadableLine` in its place, and reading goes on. Comments (``#``) and blank
    lines are skipped."""
    from can.io.canutils import CanutilsLogReader  # noqa: PLC0415

    last = [""]  # the line python-can's reader read last: the one of the message it yields
    number = [0]  # and its number
    passed: list[UnreadableLine] = []  # lines refused before python-can saw them
    cut = [False]  # the line is the file's last, no newline after it
    frames = 0
    first: UnreadableLine | None = None

    def lines() -> Iterator[str]:
        for block in bounded_line_blocks(stream, "candump"):
            cut[0] = type(block) is UnterminatedLine
            if type(block) is OverlongLine or (
                    isinstance(block, UnterminatedLine) and block.cut_short):
                number[0] += 1
                passed.append(_not_handed(block, number[0]))
                continue
            for line in block:
                number[0] += 1
                fields = line.split()
                if not fields or fields[0][0] == "#":
                    continue
                try:
                    # suspect: not ASCII, or the file's last line
                    _checked(fields, line, type(block) is not list)
                except ValueError as error:
                    passed.append(_unreadable(line, number[0], error, cut[0]))
                    continue
                last[0] = line
                yield line

    source = lines()
    messages = iter(CanutilsLogReader(source))  # type: ignore[arg-type]  # iterates it only
    while True:
        try:
            message = next(messages, None)
            if message is not None:
                message = restore_error_details(message, last[0])
                if message.timestamp - message.timestamp:
                    _not_finite(last[0].split()[0])
        except Exception as error:
            if isinstance(error, LineTooLongError) or \
                    not isinstance(error, ValueError | IndexError | KeyError | TypeError):
                raise  # a line over MAX_LINE (not a candump log), the stream failing, ...
            passed.append(_unreadable(last[0], number[0], error, cut[0]))
            # python-can's reader ends with its error: a new one goes on from the next line
            messages = iter(CanutilsLogReader(source))  # type: ignore[arg-type]
            continue
        if passed:
            first = first or passed[0]
            yield from passed
            passed.clear()
        if message is None:
            break
        frames += 1
        yield message
    if first is not None and not frames:
        raise ValueError(_no_frame(first))


#: identifier texts remembered per log (then they start over): a log has few distinct ones
_IDENTS_KEPT = 4096


_UNSEEN = (-1, False)  # an identifier text not parsed yet (no identifier is -1)


def _plain_id(ident: str) -> tuple[int, bool] | None:
    """(id, extended) of a data frame's identifier text, None where python-can's own rules
    decide (bad digits; over 7FFh in 3 digits; an error flag or more in 8)."""
    size = len(ident)
    try:
        can_id = int(ident, 16)
    except ValueError:
        return None
    if not size or (size <= 3 and can_id > 0x7FF) or can_id > 0x1FFFFFFF:
        return None
    return can_id, size > 3


def read_candump(stream: TextIO
                 ) -> Iterator[tuple[float, Frame | can.Message | UnreadableLine]]:
    """(timestamp, frame) per line: a :class:`Frame` for a classic data frame, the
    ``can.Message`` python-can reads for anything else (remote, error, CAN FD), an
    :class:`UnreadableLine` for a line that is no frame (its timestamp NaN where it has
    none). A first line over MAX_LINE raises
    :class:`~blinkcan.formats.log_source.LineTooLongError`, a later one is unreadable;
    a log none of whose lines is a frame raises ValueError once it is read."""
    new = _new_tuple
    for block in read_candump_columns(stream, PlainBlocks()):
        others = block.others
        if not others:
            for timestamp, can_id, data, extended in zip(block.times, block.ids, block.data,
                                                          block.extended, strict=True):
                yield timestamp, new(Frame, (can_id, data, extended))
            continue
        for row, (timestamp, can_id, data, extended) in enumerate(zip(
                block.times, block.ids, block.data, block.extended, strict=True)):
            other = others.get(row)
            yield timestamp, new(Frame, (can_id, data, extended)) if other is None else other


def read_candump_columns(stream: TextIO, fast: BlockReader | None = None,
                         chunk_size: int | None = None) -> Iterator[FrameColumns]:
    """The log as :class:`~blinkcan.formats.columns.FrameColumns`, a block of lines at a time,
    each frame's channel the line's; a line that is not a frame is an
    :class:`~blinkcan.formats.unreadable.UnreadableLine` among them, in its place, and
    reading goes on. Comments (``#``) and blank lines are skipped. A log none of whose lines
    is a frame raises ValueError once it is read. ``fast`` reads a block of ASCII lines
    whole where every line is a plain frame (formats/candump_columns.py), None otherwise
    (then these lines are read here); ``chunk_size``: characters per block (None: the
    default of log_source.py)."""
    idents: dict[str, tuple[int, bool] | None] = {}
    read = 0  # lines in the blocks before this one
    frames = 0
    first: UnreadableLine | None = None
    blocks = bounded_line_blocks(stream, "candump") if chunk_size is None else \
        bounded_line_blocks(stream, "candump", chunk_size)
    for lines in blocks:
        if fast is not None and type(lines) is list:
            block = fast(lines)
            if block is not None:  # every line a frame
                read += len(lines)
                frames += len(block)
                yield block
                continue
        columns = FrameColumns()
        if type(lines) is list:
            _read_lines(lines, columns, idents, read, False)
        elif isinstance(lines, UnterminatedLine) and lines.cut_short:
            columns.add_unreadable(_cut_short(lines[0], read + 1))
        elif type(lines) is OverlongLine:
            columns.add_unreadable(_overlong(lines, read + 1))
        else:  # not ASCII (a byte that is not UTF-8 is a surrogate escape), or the last line
            cut_off = type(lines) is UnterminatedLine
            start = 0
            for index, line in enumerate(lines):
                if not line.isascii() and _escaped(line):
                    _read_lines(lines[start:index], columns, idents, read + start, cut_off)
                    columns.add_unreadable(_unreadable(
                        line, read + index + 1, ValueError(f"{shown(line)} is not UTF-8 text"),
                        cut_off))
                    start = index + 1
            _read_lines(lines[start:], columns, idents, read + start, cut_off)
        read += len(lines)
        if columns.times:
            if columns.others:
                unreadable = [o for o in columns.others.values() if type(o) is UnreadableLine]
                first = first or (unreadable[0] if unreadable else None)
                frames += len(columns.times) - len(unreadable)
            else:
                frames += len(columns.times)
            yield columns
    if first is not None and not frames:
        raise ValueError(_no_frame(first))


def _read_lines(lines: list[str], columns: FrameColumns,
                idents: dict[str, tuple[int, bool] | None], read: int, cut_off: bool) -> None:
    """Lines ``read + 1`` on of a log into ``columns``."""
    fromhex = bytes.fromhex
    add_time, add_channel, add_id = (columns.times.append, columns.channels.append,
                                     columns.ids.append)
    add_extended, add_data = columns.extended.append, columns.data.append
    skipped = 0  # the lines of ``lines`` so far that are no row (blank, comments)
    rows_before = len(columns.times)
    for line in lines:
        fields = line.split()
        count = len(fields)
        if count == 3 or (count == 4 and fields[3] in _DIRECTIONS):
            stamp = fields[0]
            ident, hashed, data = fields[2].partition("#")
            plain = idents.get(ident, _UNSEEN)
            if plain is _UNSEEN:
                if len(idents) >= _IDENTS_KEPT:
                    idents.clear()
                plain = idents[ident] = _plain_id(ident)
            size = len(data)
            if plain is not None and hashed and stamp[0] == "(" and size <= 16 \
                    and not size & 1 and data[:1] not in _NOT_DATA:
                try:
                    payload = fromhex(data)
                    timestamp = float(stamp[1:-1])
                except ValueError:
                    pass
                else:
                    if not timestamp - timestamp:  # not nan or inf: x - x is 0.0 if finite
                        add_time(timestamp)
                        add_channel(fields[1])
                        add_id(plain[0])
                        add_extended(plain[1])
                        add_data(payload)
                        continue
        if not fields or fields[0][0] == "#":
            skipped += 1
            continue
        number = read + len(columns.times) - rows_before + skipped + 1
        try:
            message = _python_can(line)
            if message is None:  # python-can found nothing on a line that is not blank
                raise ValueError(f"{shown(line)} holds no frame")
            if message.timestamp - message.timestamp:
                _not_finite(fields[0])
        except Exception as error:  # python-can's reader raises what its parsing meets
            columns.add_unreadable(_unreadable(line, number, error, cut_off))
            continue
        columns.add_other(message, fields[1])


def _escaped(line: str) -> bool:
    """The line holds a byte that is not UTF-8 (a surrogate escape; ``re`` compiles the
    pattern at its first use and keeps it)."""
    return re.search("[\udc80-\udcff]", line) is not None


def _unreadable(line: str, number: int, error: Exception, cut_off: bool) -> UnreadableLine:
    """The record of line ``number``, which ``error`` says is no frame."""
    reason = str(error) or type(error).__name__
    if shown(line) not in reason:  # python-can's words ("not enough values to unpack")
        reason = (_not_whole(line) if len(line.split()) < 3
                  else f"{shown(line)} is not a candump line ({reason})")
    return UnreadableLine(number, printable(line), reason, _line_time(line), cut_off)


def _line_time(line: str) -> float | None:
    """The time a line that is no frame starts with, where it reads as one."""
    stamp = line.split(maxsplit=1)[0] if line.strip() else ""
    time = None
    if stamp[:1] == "(" and stamp[-1:] == ")":
        with contextlib.suppress(ValueError):
            time = float(stamp[1:-1])
    return time if time is not None and math.isfinite(time) else None


def _not_handed(block: list[str], number: int) -> UnreadableLine:
    """Line ``number``, no reader's to read: over MAX_LINE, or a compressed file's last, cut
    short."""
    if isinstance(block, OverlongLine):
        return _overlong(block, number)
    return _cut_short(block[0], number)


def _overlong(line: OverlongLine, number: int) -> UnreadableLine:
    """A line over MAX_LINE (its prefix; formats/log_source.py read past the rest)."""
    return UnreadableLine(number, printable(line[0]), line.reason(), _line_time(line[0]),
                          line.unterminated)


def _cut_short(line: str, number: int) -> UnreadableLine:
    """The last line of a compressed log whose compressed stream was cut short: it may have
    been cut, whole or not, so it is no frame (or, empty, the cut is at a line's end)."""
    where = f"{shown(line)} is where" if line.strip() else "there"
    reason = f"{where} the compressed file ends, before its compressed stream does: cut short"
    if number == 1 and not line:  # nothing came out: zstd's format decodes a block only
        # whole (RFC 8878 §3.1.1.3: its sequences are read from the block's end)
        reason = ("the compressed file ends before any line of it could be decompressed: cut "
                  "short (a .zst block, up to 128 KiB of text, is decompressed only whole)")
    return UnreadableLine(number, printable(line), reason, _line_time(line), True)


def _no_frame(first: UnreadableLine) -> str:
    """A log none of whose lines is a frame: not a candump log."""
    return f"no line is a candump frame ({first})"


def _not_finite(stamp: str) -> None:
    """A candump time is seconds, a finite number (DESIGN: non-finite times are bad input)."""
    raise ValueError(f"time {stamp} is not a finite number of seconds")
