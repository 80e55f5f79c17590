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

_ERROR_FLAG = 0x20000000
_trusted = Frame.trusted


def _python_can(line: str) -> can.Message | None:
    """The message python-can reads from one line (None for a blank line)."""
    reader = CanutilsLogReader(io.StringIO(line))
    return next(iter(reader), None)


def read_candump(stream: TextIO) -> Iterator[tuple[float, Frame | can.Message]]:
    """(timestamp, frame) per line: a :class:`Frame` for a classic data frame, the
    ``can.Message`` python-can reads for anything else (remote, error, CAN FD)."""
    for line in stream:
        fields = line.split()
        if (len(fields) == 3 or (len(fields) == 4 and fields[3] in ("R", "T", "r", "t"))) \
                and fields[0][:1] == "(":
            ident, _, data = fields[2].partition("#")
            if (data[:1] not in ("#", "R", "r") and not len(data) & 1
                    and (len(ident) <= 3 or not int(ident, 16) & _ERROR_FLAG)):
                try:
                    frame = _trusted(int(ident, 16), bytes.fromhex(data), len(ident) > 3)
                    timestamp = float(fields[0][1:-1])
                except ValueError:
                    pass
                else:
                    if len(frame.data) <= 8 and frame.can_id <= (
                            0x1FFFFFFF if frame.extended else 0x7FF):
                        yield timestamp, frame
                        continue
        if not fields:
            continue
        message = _python_can(line)
        if message is not None:
            yield message.timestamp, message
