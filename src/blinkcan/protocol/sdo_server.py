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

import struct
from collections.abc import Callable
from enum import IntEnum
from typing import Protocol

from blinkcan.protocol.abort import AbortCode
from blinkcan.protocol.sdo import (
    CCS_DOWNLOAD_SEGMENT,
    CCS_UPLOAD_SEGMENT,
    DOWNLOAD_ACKNOWLEDGE,
    EXPEDITED,
    EXPEDITED_UPLOAD_COMMAND,
    LAST_SEGMENT,
    SEGMENTED_UPLOAD_RESPONSE,
    SIZE_INDICATED,
    TOGGLE,
    ZEROS,
    SdoFrame,
    abort_data,
    expedited_payload,
    parse_sdo,
    segment_payload,
)

#: The largest segmented download the server buffers (both devices have only short objects).
MAX_DOWNLOAD_SIZE = 1024
_NO_MULTIPLEXER = b"\x00\x00\x00"
#: an initiate download response: the command, the request's multiplexer echoed (KBX §8),
#: four bytes reserved (CiA 301 §7.2.4.3.3); packed in one call from the parsed fields
_ACKNOWLEDGE = struct.Struct("<BHB4x")
#: client specifiers of segment requests: bytes 1-3 are data, not a multiplexer
_SEGMENT_REQUESTS = frozenset({CCS_DOWNLOAD_SEGMENT, CCS_UPLOAD_SEGMENT})
#: distinct request frames whose parse a server keeps (a master polls the same few requests)
_PARSED_KEPT = 256

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


_Handler = Callable[[SdoFrame], "bytes | None"]


class SdoServer:
    """One server channel (one per node)."""

    __slots__ = ("_buffer", "_download", "_handlers", "_idle", "_mux", "_parsed", "_position",
                 "_replies", "_segments", "_size", "_state", "_tables", "_toggle", "_upload")

    def __init__(self, access: ObjectAccess) -> None:
        self._upload = access.sdo_upload  # bound once: called on every request
        self._download = access.sdo_download
        self._state = TransferState.IDLE
        self._mux = _NO_MULTIPLEXER
        self._buffer = bytearray()
        self._position = 0
        self._toggle = 0
        self._size: int | None = None
        #: mux -> (value bytes, reply): an unchanged value object gets the same reply bytes
        #: (expedited: the reply; segmented: the initiate response, then every segment's)
        self._replies: dict[bytes, tuple[bytes, bytes | tuple[bytes, ...]]] = {}
        #: the open upload's replies: its initiate response, then its segments (``_position``:
        #: the next)
        self._segments: tuple[bytes, ...] = ()
        #: request bytes -> their parse, or for an expedited read answered before, (its parse,
        #: the value bytes, the reply): the same read of a value with the same bytes gets the
        #: same reply without a dispatch. A master polls the same requests byte
        #: for byte (a read of an object is always the same eight bytes), an SdoFrame is
        #: immutable, and parsing costs about a third of a request (a NamedTuple of seven
        #: fields; measured, benchmarks/sdo_twin.py). One table: every request looks up once.
        #: Bounded: cleared when full.
        self._parsed: dict[bytes, SdoFrame | tuple[SdoFrame, bytes, bytes]] = {}
        # state -> handler per client command specifier (0..7; CiA 301 §7.2.4.3): the protocol
        # as a table. A list per state, not a dict keyed by (state, ccs): hashing an enum costs
        # a Python call.
        refuse = self._refuse
        self._tables: dict[TransferState, list[_Handler]] = {}
        for state in TransferState:
            handlers: list[_Handler] = [refuse] * 8
            handlers[1] = self._initiate_download
            handlers[2] = self._initiate_upload
            handlers[4] = self._client_abort
            self._tables[state] = handlers
        self._tables[TransferState.UPLOADING][3] = self._upload_segment
        self._tables[TransferState.DOWNLOADING][0] = self._download_segment
        self._idle = self._tables[TransferState.IDLE]
        self._handlers = self._idle

    @property
    def state(self) -> TransferState:
        return self._state

    def reset(self) -> None:
        """Forget any open transfer (power off, NMT reset)."""
        self._enter(TransferState.IDLE)
        self._buffer = bytearray()

    def _enter(self, state: TransferState) -> None:
        self._state = state
        self._handlers = self._tables[state]

    def on_request(self, data: bytes) -> bytes | None:
        """The eight reply bytes for one request, or None (a client abort needs no reply)."""
        known = self._parsed.get(data) if data.__class__ is bytes else None  # hashable
        if isinstance(known, SdoFrame):
            return self._handlers[known.specifier](known)
        if known is not None:  # an expedited read answered before: (its parse, value, reply)
            # the value is read on every request (a reader may make it anew): the reply is
            # kept while the value's bytes are the same and no transfer is open
            request, kept, reply = known
            value = self._upload(request.mux)
            if value == kept and self._handlers is self._idle:
                return reply
            return self._answer_upload(request, value)
        request = self._parse(data)
        return self._handlers[request.specifier](request)

    def _parse(self, data: bytes) -> SdoFrame:
        # errata P10: a short request reads as padded with zeros
        request = parse_sdo(data if len(data) == 8 else (bytes(data) + ZEROS)[:8])
        if data.__class__ is bytes:  # hashable and immutable
            parsed = self._parsed
            if len(parsed) >= _PARSED_KEPT:
                parsed.clear()
            parsed[data] = request
        return request

    # -- handlers -------------------------------------------------------------------------

    def _refuse(self, request: SdoFrame) -> bytes:
        mux = self._mux if self._state is not TransferState.IDLE else _NO_MULTIPLEXER
        if request.specifier not in _SEGMENT_REQUESTS:  # a segment carries no multiplexer
            mux = request.mux
        self._enter(TransferState.IDLE)
        return abort_data(mux, AbortCode.COMMAND_SPECIFIER_INVALID)

    def _client_abort(self, request: SdoFrame) -> None:
        self._enter(TransferState.IDLE)  # CiA 301 §7.2.4.3.17: an abort is not answered

    def _initiate_upload(self, request: SdoFrame) -> bytes:
        return self._answer_upload(request, self._upload(request.mux))

    def _answer_upload(self, request: SdoFrame, value: bytes | AbortCode) -> bytes:
        """The reply to the initiate upload ``request`` of an object whose value (or refusal)
        is ``value``; a transfer still open is abandoned."""
        mux = request.mux
        if self._handlers is not self._idle:
            self._enter(TransferState.IDLE)
        cached = self._replies.get(mux)
        if cached is not None and cached[0] is value:
            reply = cached[1]
            if isinstance(reply, bytes):
                self._known(request, value, reply)
                return reply
        elif not isinstance(value, bytes):
            return abort_data(mux, value)
        else:
            size = len(value)
            if size in EXPEDITED_UPLOAD_COMMAND:  # CiA 301: 1-4 bytes go expedited
                reply = bytes((EXPEDITED_UPLOAD_COMMAND[size],)) + mux + value + ZEROS[size:4]
                self._replies[mux] = (value, reply)
                self._known(request, value, reply)
                return reply
            reply = (bytes((SEGMENTED_UPLOAD_RESPONSE,)) + mux + size.to_bytes(4, "little"),
                     *_segment_replies(value))
            self._replies[mux] = (value, reply)
        self._enter(TransferState.UPLOADING)
        self._mux = mux
        self._segments = reply
        self._position = 1
        self._toggle = 0
        return reply[0]

    def _known(self, request: SdoFrame, value: bytes, reply: bytes) -> None:
        """Keep the expedited ``reply`` to the upload ``request`` of ``value`` (``_parsed``)."""
        parsed = self._parsed
        if len(parsed) >= _PARSED_KEPT:
            parsed.clear()
        parsed[request.raw] = (request, value, reply)

    def _upload_segment(self, request: SdoFrame) -> bytes:
        # CiA 301 §7.2.4.3.7: alternates from 0 on each segment (SdoFrame.toggle, inlined)
        if request.command & TOGGLE != self._toggle:
            self._enter(TransferState.IDLE)
            return abort_data(self._mux, AbortCode.TOGGLE_BIT_NOT_ALTERNATED)
        position = self._position
        self._position = position + 1
        self._toggle ^= TOGGLE
        segments = self._segments
        if position + 1 == len(segments):  # the last one
            self._enter(TransferState.IDLE)
        return segments[position]

    def _initiate_download(self, request: SdoFrame) -> bytes:
        command, mux = request.command, request.mux  # read once: properties cost a call
        if self._handlers is not self._idle:
            self._enter(TransferState.IDLE)
        if command & EXPEDITED:  # CiA 301 §7.2.4.3.3: n bytes if the size is indicated, else 4
            result = self._download(mux, expedited_payload(command, request.raw),
                                    command & SIZE_INDICATED == SIZE_INDICATED)
            if result > 0xFF:
                return abort_data(mux, result)
            return _ACKNOWLEDGE.pack(result, request.object_index, request.subindex)
        size = request.size
        if size is not None and size > MAX_DOWNLOAD_SIZE:
            return abort_data(mux, AbortCode.OUT_OF_MEMORY)
        self._enter(TransferState.DOWNLOADING)
        self._mux = mux
        self._size = size
        self._buffer = bytearray()
        self._toggle = 0
        return bytes((DOWNLOAD_ACKNOWLEDGE,)) + mux + b"\x00\x00\x00\x00"

    def _download_segment(self, request: SdoFrame) -> bytes:
        command = request.command
        toggle = command & TOGGLE  # CiA 301 §7.2.4.3.4: alternates from 0 on each segment
        if toggle != self._toggle:
            self._enter(TransferState.IDLE)
            return abort_data(self._mux, AbortCode.TOGGLE_BIT_NOT_ALTERNATED)
        self._buffer += segment_payload(request.raw)
        if len(self._buffer) > MAX_DOWNLOAD_SIZE:
            self._enter(TransferState.IDLE)
            return abort_data(self._mux, AbortCode.OUT_OF_MEMORY)
        self._toggle ^= TOGGLE
        reply = bytes((0x20 | toggle,)) + ZEROS[:7]
        if not command & LAST_SEGMENT:
            return reply
        self._enter(TransferState.IDLE)
        if self._size is not None and self._size != len(self._buffer):
            return abort_data(self._mux, AbortCode.DATA_TYPE_LENGTH_MISMATCH)
        result = self._download(self._mux, bytes(self._buffer), True)
        if result > 0xFF:
            return abort_data(self._mux, result)
        return reply


def _segment_replies(value: bytes) -> tuple[bytes, ...]:
    """The upload segment responses that carry ``value``, in order (CiA 301 §7.2.4.3.7):
    seven bytes each, the toggle bit alternating from 0, n (bits 3-1) the bytes unused, c (bit
    0) on the last; an empty value is one empty last segment."""
    replies = []
    for start in range(0, max(len(value), 1), 7):
        chunk = value[start : start + 7]
        toggle = TOGGLE if start // 7 % 2 else 0
        last = start + 7 >= len(value)
        replies.append(bytes((toggle | ((7 - len(chunk)) << 1) | last,)) + chunk
                       + ZEROS[len(chunk) : 7])
    return tuple(replies)
