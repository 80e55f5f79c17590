"""candump ``-L`` log lines (``(1700000000.000500) can0 715#05``) read straight into frames.

Why not python-can's ``CanutilsLogReader`` for every line: it builds a ``can.Message`` and
parses the data two hex digits at a time, about 4 us a frame, which is more than half of the
whole budget of ``blinkcan decode --json`` (DESIGN.md: 1.5x python-can + cantools + json). A
plain data-frame line is split once and its data read by ``bytes.fromhex``, about 1 us.

Every other line (remote frames ``R``, CAN FD ``##``, error-flag identifiers, odd digit counts,
anything unusual) is handed to python-can's own reader, one line at a time, so the result is
python-can's by construction; tests/formats/test_candump.py checks the fast path against
python-can's reader on generated logs.
"""

from __future__ import annotations

import io
from collections.abc import Iterator
from typing import TextIO

import can
from can.io.canutils import CanutilsLogReader

from blinkcan.protocol.frame import Frame

_DIRECTIONS = frozenset({"R", "T", "r", "t"})
_NOT_DATA = frozenset({"#", "R", "r"})  # CAN FD, remote
_new_tuple = tuple.__new__  # Frame.trusted without the call: the ids and data are checked here


def _python_can(line: str) -> can.Message | None:
    """The message python-can reads from one line (None for a blank line)."""
    reader = CanutilsLogReader(io.StringIO(line))
    return next(iter(reader), None)


def read_candump(stream: TextIO) -> Iterator[tuple[float, Frame | can.Message]]:
    """(timestamp, frame) per line: a :class:`Frame` for a classic data frame, the
    ``can.Message`` python-can reads for anything else (remote, error, CAN FD)."""
    new = _new_tuple
    fromhex = bytes.fromhex
    for line in stream:
        fields = line.split()
        count = len(fields)
        if count == 3 or (count == 4 and fields[3] in _DIRECTIONS):
            stamp = fields[0]
            ident, _, data = fields[2].partition("#")
            size = len(ident)
            if stamp[:1] == "(" and size and len(data) <= 16 and not len(data) & 1 \
                    and data[:1] not in _NOT_DATA:
                try:
                    can_id = int(ident, 16)
                    payload = fromhex(data)
                    timestamp = float(stamp[1:-1])
                except ValueError:
                    pass
                else:
                    if size <= 3:
                        if can_id <= 0x7FF:
                            yield timestamp, new(Frame, (can_id, payload, False))
                            continue
                    elif can_id <= 0x1FFFFFFF:  # not an error flag: python-can's own rules
                        yield timestamp, new(Frame, (can_id, payload, True))
                        continue
        if not fields:
            continue
        message = _python_can(line)
        if message is not None:
            yield message.timestamp, message
