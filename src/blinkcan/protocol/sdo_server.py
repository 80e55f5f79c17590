"""SDO server: the state machine that answers SDO requests (CiA 301 §7.2.4.3).

Our own, not python-canopen's ``SdoServer``: a faithful twin needs every request answered with
the exact bytes the manuals print (including the quirks of errata.md), including while a
transfer is in progress, and needs no network object. Bytes in, bytes out.

Rules:
- A request shorter than eight bytes is read as if padded with zeros (errata P10: the keypad's
  J1939 switch is printed as a five-byte frame).
- Expedited and segmented upload and download; the toggle bit is checked on every segment.
- A new initiate request while a segmented transfer is open abandons the open one.
- Every request gets exactly one reply, except an abort from the client, which gets none.
- Block transfer is not supported by either device: 0504 0001h.
"""

from __future__ import annotations

from collections.abc import Callable
from enum import IntEnum
from typing import Protocol

from blinkcan.protocol.abort import AbortCode
from blinkcan.protocol.sdo import (
    DOWNLOAD_ACKNOWLEDGE,
    EXPEDITED_UPLOAD_COMMAND,
    SEGMENTED_UPLOAD_RESPONSE,
    TOGGLE,
    ZEROS,
    abort_data,
    expedited_payload,
)

#: The largest segmented download the server buffers (both devices have only short objects).
MAX_DOWNLOAD_SIZE = 1024
_NO_MULTIPLEXER = b"\x00\x00\x00"


class ObjectAccess(Protocol):
    """What the server needs from an object dictionary. ``mux`` is the 3-byte multiplexer."""

    def sdo_upload(self, mux: bytes) -> bytes | AbortCode:
        """The value's bytes, or the abort code that refuses the read."""
        ...

    def sdo_download(self, mux: bytes, data: bytes, size_indicated: bool) -> int:
        """Store ``data``. Returns the acknowledge command byte (60h, or a device quirk such
        as 43h) or an :class:`AbortCode` (always > FFh). Without ``size_indicated`` the data
        is four bytes and the object takes as many as its type needs."""
        ...


class TransferState(IntEnum):
    IDLE = 0
    UPLOADING = 1
    DOWNLOADING = 2


_Handler = Callable[[bytes], "bytes | None"]


class SdoServer:
    """One server channel (one per node)."""

    __slots__ = ("_access", "_buffer", "_mux", "_position", "_size", "_state", "_table", "_toggle")

    def __init__(self, access: ObjectAccess) -> None:
        self._access = access
        self._state = TransferState.IDLE
        self._mux = _NO_MULTIPLEXER
        self._buffer = bytearray()
        self._position = 0
        self._toggle = 0
        self._size: int | None = None
        initiate_upload, initiate_download = self._initiate_upload, self._initiate_download
        abort, refuse = self._client_abort, self._refuse
        # (state, client command specifier) -> handler: the whole protocol as a table.
        self._table: dict[tuple[TransferState, int], _Handler] = {}
        for state in TransferState:
            for ccs in range(8):
                self._table[state, ccs] = refuse
            self._table[state, 1] = initiate_download
            self._table[state, 2] = initiate_upload
            self._table[state, 4] = abort
        self._table[TransferState.UPLOADING, 3] = self._upload_segment
        self._table[TransferState.DOWNLOADING, 0] = self._download_segment

    @property
    def state(self) -> TransferState:
        return self._state

    def reset(self) -> None:
        """Forget any open transfer (power off, NMT reset)."""
        self._state = TransferState.IDLE
        self._buffer = bytearray()

    def on_request(self, data: bytes) -> bytes | None:
        """The eight reply bytes for one request, or None (a client abort needs no reply)."""
        if len(data) < 8:
            data = data + ZEROS[len(data) :]
        return self._table[self._state, data[0] >> 5](data)

    # -- handlers -------------------------------------------------------------------------

    def _refuse(self, data: bytes) -> bytes:
        mux = self._mux if self._state is not TransferState.IDLE else _NO_MULTIPLEXER
        if data[0] >> 5 not in (0, 3):  # segment frames carry data, not a multiplexer
            mux = data[1:4]
        self._state = TransferState.IDLE
        return abort_data(mux, AbortCode.COMMAND_SPECIFIER_INVALID)

    def _client_abort(self, data: bytes) -> None:
        self._state = TransferState.IDLE
        return None

    def _initiate_upload(self, data: bytes) -> bytes:
        mux = data[1:4]
        self._state = TransferState.IDLE
        value = self._access.sdo_upload(mux)
        if type(value) is not bytes:
            return abort_data(mux, value)
        size = len(value)
        if 0 < size <= 4:
            return bytes((EXPEDITED_UPLOAD_COMMAND[size],)) + mux + value + ZEROS[size:4]
        self._state = TransferState.UPLOADING
        self._mux = mux
        self._buffer = bytearray(value)
        self._position = 0
        self._toggle = 0
        return bytes((SEGMENTED_UPLOAD_RESPONSE,)) + mux + size.to_bytes(4, "little")

    def _upload_segment(self, data: bytes) -> bytes:
        toggle = data[0] & TOGGLE
        if toggle != self._toggle:
            self._state = TransferState.IDLE
            return abort_data(self._mux, AbortCode.TOGGLE_BIT_NOT_ALTERNATED)
        start = self._position
        chunk = bytes(self._buffer[start : start + 7])
        self._position = start + len(chunk)
        last = self._position >= len(self._buffer)
        self._toggle ^= TOGGLE
        if last:
            self._state = TransferState.IDLE
        command = toggle | ((7 - len(chunk)) << 1) | last
        return bytes((command,)) + chunk + ZEROS[len(chunk) : 7]

    def _initiate_download(self, data: bytes) -> bytes:
        command, mux = data[0], data[1:4]
        self._state = TransferState.IDLE
        if command & 0x02:  # expedited
            result = self._access.sdo_download(
                mux, expedited_payload(command, data), bool(command & 0x01)
            )
            if result > 0xFF:
                return abort_data(mux, result)
            return bytes((result,)) + mux + b"\x00\x00\x00\x00"
        size = int.from_bytes(data[4:8], "little") if command & 0x01 else None
        if size is not None and size > MAX_DOWNLOAD_SIZE:
            return abort_data(mux, AbortCode.OUT_OF_MEMORY)
        self._state = TransferState.DOWNLOADING
        self._mux = mux
        self._size = size
        self._buffer = bytearray()
        self._toggle = 0
        return bytes((DOWNLOAD_ACKNOWLEDGE,)) + mux + b"\x00\x00\x00\x00"

    def _download_segment(self, data: bytes) -> bytes:
        command = data[0]
        toggle = command & TOGGLE
        if toggle != self._toggle:
            self._state = TransferState.IDLE
            return abort_data(self._mux, AbortCode.TOGGLE_BIT_NOT_ALTERNATED)
        self._buffer += data[1 : 8 - ((command >> 1) & 0x07)]
        if len(self._buffer) > MAX_DOWNLOAD_SIZE:
            self._state = TransferState.IDLE
            return abort_data(self._mux, AbortCode.OUT_OF_MEMORY)
        self._toggle ^= TOGGLE
        reply = bytes((0x20 | toggle,)) + ZEROS[:7]
        if not command & 0x01:
            return reply
        self._state = TransferState.IDLE
        if self._size is not None and self._size != len(self._buffer):
            return abort_data(self._mux, AbortCode.DATA_TYPE_LENGTH_MISMATCH)
        result = self._access.sdo_download(self._mux, bytes(self._buffer), True)
        if result > 0xFF:
            return abort_data(self._mux, result)
        return reply
