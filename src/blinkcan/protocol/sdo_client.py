"""SDO client: one transfer at a time as a pure state machine (CiA 301 §7.2.4.3).

Our own, not python-canopen's ``SdoClient``: the stock client rejects the Keybox's 43h download
acknowledge (errata K3) and needs a network object. Bytes in, bytes out; the host layer sends
them and waits. Lenient exactly where the manuals show device quirks, strict everywhere else:
- a download acknowledged with 43h instead of 60h succeeds (errata K3, G5);
- an expedited upload may state another size than the object's type (errata P3: 4Fh for a
  16-bit value); the bytes are returned as sent and the caller decodes them by type.
A reply for another object, a wrong toggle bit or an unknown command is an error.
"""

from __future__ import annotations

from blinkcan.errors import BlinkcanError
from blinkcan.protocol.abort import describe_abort
from blinkcan.protocol.sdo import (
    EXPEDITED_DOWNLOAD_COMMAND,
    EXPEDITED_END,
    EXPEDITED_UPLOAD,
    EXPEDITED_UPLOAD_MASK,
    LAST_SEGMENT,
    SCS_DOWNLOAD_SEGMENT,
    SCS_INITIATE_UPLOAD,
    SCS_UPLOAD_SEGMENT,
    SIZE_INDICATED,
    TOGGLE,
    ZEROS,
    SdoFrame,
    multiplexer,
    parse_sdo,
)

QUIRK_ACKNOWLEDGES = frozenset({0x60, 0x43})  # errata K3: the firmware acknowledges with 43h
#: an initiate upload response that opens a segmented upload: scs 2, e clear
_SEGMENTED_UPLOAD = SCS_INITIATE_UPLOAD << 5
#: the upload segment requests (CiA 301 §7.2.4.3.7: ccs 3), toggle bit clear and set
_SEGMENT_REQUESTS = (b"\x60" + ZEROS[:7], b"\x70" + ZEROS[:7])


class SdoError(BlinkcanError):
    """An SDO transfer failed; names the node, object and sub-index."""

    def __init__(self, message: str, node_id: int | None = None, index: int = 0,
                 subindex: int = 0) -> None:
        self.node_id = node_id
        self.index = index
        self.subindex = subindex
        where = f"{index:04X}h/{subindex:02X}"
        who = f"node {node_id:02X}h " if node_id is not None else ""
        super().__init__(f"{who}{where}: {message}")


class SdoAbortError(SdoError):
    """The device refused the transfer with an abort code."""

    def __init__(self, code: int, node_id: int | None = None, index: int = 0,
                 subindex: int = 0) -> None:
        self.code = code
        super().__init__(f"aborted {code:08X}h, {describe_abort(code)}", node_id, index,
                         subindex)


class SdoTimeoutError(SdoError):
    """No reply within the timeout, after the retries. ``uncertain``: a write whose effect is
    unknown (the device may have applied it and its acknowledge been late or lost)."""

    uncertain: bool = False


class SdoProtocolError(SdoError):
    """A reply that does not fit the transfer."""


class _Transfer:
    def __init__(self, index: int, subindex: int) -> None:
        self.index = index
        self.subindex = subindex
        self.mux = multiplexer(index, subindex)
        self.done = False

    def _fail(self, message: str) -> SdoProtocolError:
        return SdoProtocolError(message, None, self.index, self.subindex)

    def _check_common(self, data: bytes) -> SdoFrame:
        """The reply parsed; an abort (CiA 301 §7.2.4.3.17) or a short frame raised."""
        if len(data) < 8:
            raise self._fail(f"reply of {len(data)} bytes, SDO frames have 8")
        reply = parse_sdo(data[:8])
        if reply.is_abort:
            if reply.mux not in (self.mux, b"\x00\x00\x00"):
                raise self._fail("abort for another object")
            raise SdoAbortError(reply.word, None, self.index, self.subindex)
        return reply

    def abort_request(self, code: int) -> bytes:
        """The frame that tells the server to give up this transfer."""
        return b"\x80" + self.mux + code.to_bytes(4, "little")


class UploadTransfer(_Transfer):
    """Read one object: :meth:`start`, then feed replies to :meth:`on_reply` until ``done``.

    Its own state starts as these class defaults (no ``__init__`` of its own: most reads are
    one expedited reply); a segmented upload gets its buffer when the server announces it."""

    value: bytes = b""
    _size: int | None = None
    _toggle = 0
    _buffer: bytes | bytearray = b""

    @property
    def size(self) -> int | None:
        """The size the server announced (CiA 301 §7.2.4.3.6), None before or where none was."""
        return self._size if self._size != -1 else None

    @property
    def received(self) -> int:
        """How many bytes the segments brought so far."""
        return len(self._buffer)

    def again(self) -> UploadTransfer:
        """The same transfer, from its start (a retry)."""
        return UploadTransfer(self.index, self.subindex)

    def start(self) -> bytes:
        return b"\x40" + self.mux + b"\x00\x00\x00\x00"

    def on_reply(self, data: bytes) -> bytes | None:
        """The next request, or None when the value is complete (then ``done``)."""
        if len(data) == 8:  # the common replies, taken without parsing the frame
            command = data[0]
            if self._size is not None or self._buffer:  # a segmented upload under way
                if command >> 5 == SCS_UPLOAD_SEGMENT:
                    # CiA 301 §7.2.4.3.4: bytes 1-7 less the n unused ones (bits 3-1)
                    # (protocol.sdo.segment_payload, inlined)
                    return self._segment(command, data[1 : 8 - ((command >> 1) & 0x07)])
            elif data[1:4] == self.mux:
                opening = command & EXPEDITED_UPLOAD_MASK
                if opening == EXPEDITED_UPLOAD:
                    # CiA 301 §7.2.4.3.6: the value in the reply, n bytes where the size is
                    # stated, else all four (protocol.sdo.expedited_payload, inlined)
                    self.value = data[4 : EXPEDITED_END[command]]
                    self.done = True
                    return None
                if opening == _SEGMENTED_UPLOAD:
                    # CiA 301 §7.2.4.3.6: a segmented upload opens; bytes 4-7 give its size
                    # where s is set (SdoFrame.size, inlined)
                    self._size = (int.from_bytes(data[4:8], "little")
                                  if command & SIZE_INDICATED else -1)
                    self._buffer = bytearray()
                    return _SEGMENT_REQUESTS[0]
        reply = self._check_common(data)
        command = reply.command
        if self._size is None and not self._buffer and reply.specifier == SCS_INITIATE_UPLOAD:
            if reply.mux != self.mux:
                raise self._fail(f"reply for {(reply.object_index, reply.subindex)}")
            if reply.expedited:  # CiA 301 §7.2.4.3.6: size stated or all four bytes
                self.value = reply.expedited_data
                self.done = True
                return None
            size = reply.size
            self._size = -1 if size is None else size
            self._buffer = bytearray()
            return _SEGMENT_REQUESTS[0]
        if reply.specifier != SCS_UPLOAD_SEGMENT:
            raise self._fail(f"unexpected reply {command:02X}h")
        return self._segment(command, reply.segment_data)

    def _segment(self, command: int, chunk: bytes) -> bytes | None:
        """An upload segment response (``command``, its data ``chunk``): the next request."""
        if command & TOGGLE != self._toggle:  # CiA 301 §7.2.4.3.7
            raise self._fail("toggle bit not alternated")
        self._buffer += chunk
        if command & LAST_SEGMENT:  # last segment (errata B6: strings of any length)
            if self._size not in (None, -1) and len(self._buffer) != self._size:
                raise self._fail(f"{len(self._buffer)} bytes, {self._size} announced")
            self.value = bytes(self._buffer)
            self.done = True
            return None
        toggle = self._toggle = self._toggle ^ TOGGLE
        return _SEGMENT_REQUESTS[1] if toggle else _SEGMENT_REQUESTS[0]


class DownloadTransfer(_Transfer):
    """Write one object, expedited for up to 4 bytes, segmented above."""

    def __init__(self, index: int, subindex: int, data: bytes) -> None:
        super().__init__(index, subindex)
        self.data = bytes(data)
        self._position = 0
        self._toggle = 0
        self._segmented = len(self.data) > 4 or not self.data

    def again(self) -> DownloadTransfer:
        """The same transfer, from its start (a retry)."""
        return DownloadTransfer(self.index, self.subindex, self.data)

    def start(self) -> bytes:
        data = self.data
        if not self._segmented:
            command = EXPEDITED_DOWNLOAD_COMMAND[len(data)]
            return bytes((command,)) + self.mux + data + ZEROS[len(data) : 4]
        return b"\x21" + self.mux + len(data).to_bytes(4, "little")

    def on_reply(self, data: bytes) -> bytes | None:
        reply = self._check_common(data)
        command = reply.command
        if self._position == 0 and command in QUIRK_ACKNOWLEDGES and reply.mux == self.mux:
            if not self._segmented:
                self.done = True
                return None
            return self._next_segment()
        # CiA 301 §7.2.4.3.4: a segment's response echoes its toggle bit
        if self._segmented and reply.specifier == SCS_DOWNLOAD_SEGMENT and \
                reply.toggle == self._toggle ^ TOGGLE:
            if self._position >= len(self.data):
                self.done = True
                return None
            return self._next_segment()
        raise self._fail(f"unexpected reply {command:02X}h")

    def _next_segment(self) -> bytes:
        chunk = self.data[self._position : self._position + 7]
        self._position += len(chunk)
        last = self._position >= len(self.data)
        command = self._toggle | ((7 - len(chunk)) << 1) | last
        self._toggle ^= TOGGLE
        return bytes((command,)) + chunk + ZEROS[len(chunk) : 7]
