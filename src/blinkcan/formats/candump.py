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
file without newlines is refused at its first line, never read whole.
"""

from __future__ import annotations

import io
from collections.abc import Iterator
from typing import TYPE_CHECKING, TextIO

from blinkcan.formats.columns import FrameColumns
from blinkcan.formats.log_source import (
    CutOffError,
    LineTooLongError,
    UnterminatedLine,
    bounded_line_blocks,
    bounded_lines,
)
from blinkcan.protocol.frame import Frame

if TYPE_CHECKING:  # python-can loads for the first unusual line (start-up: issue 22)
    import can

_ERROR_FLAG = 0x20000000  # linux/can.h CAN_ERR_FLAG
_DIRECTIONS = frozenset({"R", "T", "r", "t"})
_NOT_DATA = frozenset({"#", "R", "r"})  # CAN FD, remote
_new_tuple = tuple.__new__  # Frame.trusted without the call: the ids and data are checked here


def _python_can(line: str) -> can.Message | None:
    """The message python-can reads from one line (None for a blank line)."""
    from can.io.canutils import CanutilsLogReader  # noqa: PLC0415

    fields = line.split()
    if 0 < len(fields) < 3:  # e.g. the last line of a capture cut off by a killed candump
        raise _plainly(line, ValueError(line))
    if len(fields) >= 3 and len(fields[2].partition("#")[0]) > 8:
        # candump writes 3 hex digits (11-bit) or 8 (29-bit, with the error flag): python-can
        # would read the flag bits of a longer identifier and call the line an error frame
        raise ValueError(f"identifier {fields[2].partition('#')[0]} has more than 8 hex digits")
    reader = CanutilsLogReader(io.StringIO(line))
    message = next(iter(reader), None)
    return restore_error_details(message, line) if message is not None else None


def _shown(line: str) -> str:
    """A line as an error message names it: quoted, at most 40 characters."""
    text = line.strip()
    return repr(text if len(text) <= 40 else text[:40] + "...")


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


def candump_messages(stream: TextIO) -> Iterator[can.Message]:
    """python-can's messages of a candump log, each error frame completed from its line, the
    lines bounded: one pass, so a stream is read once."""
    last = [""]  # the line python-can's reader read last: the one of the message it yields
    number = [0]  # and its number

    def lines() -> Iterator[str]:
        for line in bounded_lines(stream, "candump"):
            last[0] = line
            number[0] += 1
            yield line

    from can.io.canutils import CanutilsLogReader  # noqa: PLC0415

    messages = iter(CanutilsLogReader(lines()))  # type: ignore[arg-type]  # iterates it only
    while True:
        try:
            message = next(messages, None)
            if message is None:
                return
            message = restore_error_details(message, last[0])
        except (LineTooLongError, UnicodeDecodeError):
            raise  # they name their place themselves
        except Exception as error:
            raise _on_line(number[0], _plainly(last[0], error)) from error
        yield message


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


def read_candump(stream: TextIO) -> Iterator[tuple[float, Frame | can.Message]]:
    """(timestamp, frame) per line: a :class:`Frame` for a classic data frame, the
    ``can.Message`` python-can reads for anything else (remote, error, CAN FD). Lines over
    MAX_LINE raise :class:`~blinkcan.formats.log_source.LineTooLongError`."""
    new = _new_tuple
    for block in read_candump_columns(stream):
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


def read_candump_columns(stream: TextIO) -> Iterator[FrameColumns]:
    """The log as :class:`~blinkcan.formats.columns.FrameColumns`, a block of lines at a time,
    each frame's channel the line's; a line that cannot be read raises once the frames before
    it are yielded."""
    fromhex = bytes.fromhex
    idents: dict[str, tuple[int, bool] | None] = {}
    read = 0  # lines in the blocks before this one
    for lines in bounded_line_blocks(stream, "candump"):
        columns = FrameColumns()
        add_time, add_channel, add_id = (columns.times.append, columns.channels.append,
                                         columns.ids.append)
        add_extended, add_data = columns.extended.append, columns.data.append
        try:
            for line in lines:
                fields = line.split()
                count = len(fields)
                if count == 3 or (count == 4 and fields[3] in _DIRECTIONS):
                    stamp = fields[0]
                    ident, _, data = fields[2].partition("#")
                    plain = idents.get(ident, _UNSEEN)
                    if plain is _UNSEEN:
                        if len(idents) >= _IDENTS_KEPT:
                            idents.clear()
                        plain = idents[ident] = _plain_id(ident)
                    size = len(data)
                    if plain is not None and stamp[0] == "(" and size <= 16 and not size & 1 \
                            and data[:1] not in _NOT_DATA:
                        try:
                            payload = fromhex(data)
                            timestamp = float(stamp[1:-1])
                        except ValueError:
                            pass
                        else:
                            if timestamp - timestamp:  # nan or inf: x - x is 0.0 if finite
                                _not_finite(stamp)
                            add_time(timestamp)
                            add_channel(fields[1])
                            add_id(plain[0])
                            add_extended(plain[1])
                            add_data(payload)
                            continue
                if not fields:
                    continue
                message = _python_can(line)
                if message is not None:
                    if message.timestamp - message.timestamp:
                        _not_finite(fields[0])
                    columns.add_other(message, fields[1] if count > 1 else None)
        except Exception as error:
            if columns.times:  # the frames before the line, then what is wrong with it
                yield columns
            # the first line of the block that reads so (a line reads the same every time)
            raise _failed_line(lines, read + lines.index(line) + 1, error) from error
        read += len(lines)
        if columns.times:
            yield columns


def _plainly(line: str, error: Exception) -> Exception:
    """python-can's error for a line, said as a user reads it when the line is not whole
    (python-can says "not enough values to unpack")."""
    if 0 < len(line.split()) < 3:
        return ValueError(f"{_shown(line)} is not a whole candump line ((TIME) CHANNEL ID#DATA)")
    return error


def _failed_line(lines: list[str], number: int, error: Exception) -> ValueError:
    """The error of line ``number`` of ``lines``: :class:`CutOffError` when it is the file's
    last line with no newline after it (a capture cut off by a killed logger)."""
    failed = _on_line(number, error)
    if isinstance(lines, UnterminatedLine):
        return CutOffError(f"{failed}: the capture ends there, cut off")
    return failed


def _on_line(number: int, error: Exception) -> ValueError:
    """``error`` of a candump line, naming the line (1-based) so a user can find it."""
    return ValueError(f"line {number}: {str(error) or type(error).__name__}")


def _not_finite(stamp: str) -> None:
    """A candump time is seconds, a finite number (DESIGN: non-finite times are bad input);
    raised as python-can's reader raises for a time it cannot read, so callers name the file."""
    raise ValueError(f"time {stamp} is not a finite number of seconds")
