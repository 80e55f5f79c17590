"""Whether a ``can.Message`` that a log reader or a bus built is a CAN frame at all.

python-can builds a message from what a file or a datagram says and checks little of it: its
text log readers (ASC, CSV, TRC) and its SQLite reader take an identifier of 48 bits, a time of
``inf`` or ``nan`` and a DLC of 99 over one data byte as they are, and ``udp_multicast``
checks the ranges of a datagram's numbers but not their types (an identifier 1.5, a flag
``"yes"``). Such a message is no frame: the decoder and every log writer fail on it. A reader
makes it an unreadable line in its place (formats/text_logs.py, formats/logs.py), a live bus
one more bus error (cli/bus_faults.py), so it never ends a conversion or a recording.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import can

#: the flags of a ``can.Message``: each a bool (or 0/1) on a frame
_FLAGS = ("is_extended_id", "is_remote_frame", "is_error_frame", "is_fd", "bitrate_switch",
          "error_state_indicator", "is_rx")
#: ISO 11898-1: the highest 11-bit and 29-bit identifiers
_LAST_STANDARD_ID = 0x7FF
_LAST_EXTENDED_ID = 0x1FFFFFFF
#: a classic frame's DLC field is 4 bits (9-15 mean 8 bytes), CAN FD carries up to 64 bytes
_LAST_CLASSIC_DLC = 15
_CLASSIC_BYTES = 8
_FD_BYTES = 64


def wrong_type(message: can.Message) -> str | None:
    """Why ``message`` is no frame by a field of the wrong type (an identifier 1.5, a DLC
    True, a flag "yes", a time that is no finite number), or None."""
    for name, value in (("identifier", message.arbitration_id), ("DLC", message.dlc)):
        if not isinstance(value, int) or isinstance(value, bool):
            return f"{name} {value!r} is not an integer"
    for flag in _FLAGS:
        value = getattr(message, flag)
        if not isinstance(value, int) or value not in (0, 1):
            return f"{flag} {value!r} is not a bool"
    stamp = message.timestamp
    if isinstance(stamp, bool) or not isinstance(stamp, (int, float)) or \
            not math.isfinite(stamp):
        return f"time {stamp!r} is not a finite number of seconds"
    return None


def why_no_frame(message: can.Message) -> str | None:
    """Why ``message`` is no CAN frame, or None when it is one: :func:`wrong_type`, then
    python-can's own rules (``Message(check=True)``), but a classic DLC of 9-15 (8 bytes)
    kept, a CAN FD frame's DLC not compared with its data (python-can's readers give it
    three ways) and a time before 1970 allowed (a relative log's)."""
    if (wrong := wrong_type(message)) is not None:
        return wrong
    can_id, dlc, size = message.arbitration_id, message.dlc, len(message.data)
    last_id = _LAST_EXTENDED_ID if message.is_extended_id else _LAST_STANDARD_ID
    if not message.is_error_frame and not 0 <= can_id <= last_id:
        bits = 29 if message.is_extended_id else 11
        return f"identifier {can_id:X}h is no {bits}-bit identifier"
    if message.is_remote_frame:
        if message.is_error_frame or message.is_fd:
            return "a remote frame is neither an error frame nor CAN FD"
        if size or not 0 <= dlc <= _LAST_CLASSIC_DLC:
            return f"a remote frame carries no data and a DLC of 0..{_LAST_CLASSIC_DLC}"
        return None
    if message.is_fd:  # the length is the data's: python-can's readers give the DLC as the
        if size > _FD_BYTES:  # length, as its code (TRC: 9 for 12 bytes) or otherwise (BLF)
            return f"{size} data bytes are no CAN FD frame (at most {_FD_BYTES})"
    elif not (0 <= dlc <= _LAST_CLASSIC_DLC and size == min(dlc, _CLASSIC_BYTES)):
        return f"DLC {dlc} with {size} data bytes is no CAN frame"
    elif message.bitrate_switch or message.error_state_indicator:
        return "bit rate switch and error state indicator are CAN FD's only"
    return None
