"""SDO frame layout shared by the server and client state machines (CiA 301 §7.2.4.3).

Every SDO frame is eight bytes: a command byte, the multiplexer (index LSB first, then
sub-index; KBX §8 "Every answer has index and sub index echo") and four data bytes.
"""

from __future__ import annotations

import struct
from typing import NamedTuple

from blinkcan.errors import BlinkcanError
from blinkcan.protocol.abort import AbortCode

#: Client command specifiers (bits 7-5 of byte 0 of a request).
CCS_DOWNLOAD_SEGMENT = 0
CCS_INITIATE_DOWNLOAD = 1
CCS_INITIATE_UPLOAD = 2
CCS_UPLOAD_SEGMENT = 3
CCS_ABORT = 4
CCS_BLOCK_UPLOAD = 5
CCS_BLOCK_DOWNLOAD = 6

#: Server command specifiers (bits 7-5 of byte 0 of a reply).
SCS_UPLOAD_SEGMENT = 0
SCS_DOWNLOAD_SEGMENT = 1
SCS_INITIATE_UPLOAD = 2
SCS_INITIATE_DOWNLOAD = 3
SCS_ABORT = 4

DOWNLOAD_ACKNOWLEDGE = 0x60  # initiate download response
SEGMENTED_UPLOAD_RESPONSE = 0x41  # initiate upload response, size indicated, not expedited
ABORT = 0x80
TOGGLE = 0x10
#: Initiate frames, byte 0: the e bit (data in bytes 4-7) and the s bit (a size is given)
#: (CiA 301 §7.2.4.3.3, §7.2.4.3.6)
EXPEDITED = 0x02
SIZE_INDICATED = 0x01
#: Segment frames, byte 0: the c bit, no more segments follow (CiA 301 §7.2.4.3.4)
LAST_SEGMENT = 0x01

#: Expedited upload reply command by value length: PKP §15 4Bh (2 bytes), §26 43h (4), §32 4Fh (1).
EXPEDITED_UPLOAD_COMMAND = {1: 0x4F, 2: 0x4B, 3: 0x47, 4: 0x43}
#: Expedited download request command by value length: PKP §16 2Bh, §18 2Fh, KBX §28 23h.
EXPEDITED_DOWNLOAD_COMMAND = {1: 0x2F, 2: 0x2B, 3: 0x27, 4: 0x23}

ZEROS = b"\x00" * 8
#: byte 0 of an expedited initiate upload response, masked to scs (bits 7-5) and e (bit 1)
#: (CiA 301 §7.2.4.3.6): the common reply, which clients take without parsing the frame
EXPEDITED_UPLOAD_MASK = 0xE0 | EXPEDITED
EXPEDITED_UPLOAD = (SCS_INITIATE_UPLOAD << 5) | EXPEDITED
_MULTIPLEXER = struct.Struct("<HB")
#: CiA 301 §7.2.4.3: command byte, index (LSB first), sub-index, four data bytes
_SDO_LAYOUT = struct.Struct("<BHBI")
_new_tuple = tuple.__new__
#: server specifiers that answer an initiate upload request (CiA 301 §7.2.4.3.6, §7.2.4.3.17)
_ANSWERS_UPLOAD = frozenset({SCS_INITIATE_UPLOAD, SCS_ABORT})


class SdoFrameError(BlinkcanError, ValueError):
    """Bytes that are not an SDO frame: CiA 301 §7.2.4.3 frames are exactly eight bytes."""


class SdoFrame(NamedTuple):
    """One CiA 301 SDO frame, parsed (:func:`parse_sdo`); immutable, equal by value.

    The parse does not depend on the direction: ``specifier`` is bits 7-5 of byte 0, which a
    request calls the client command specifier (``CCS_*``) and a reply the server one
    (``SCS_*``). Every field of the layouts is offered; the caller, who knows the direction
    and the specifier, reads the ones that frame has (a segment has no multiplexer: its
    ``object_index``, ``subindex`` and ``mux`` are data bytes). The fields every frame is read
    by (command, specifier, multiplexer) are computed once, in the parse: a server reads them
    on every request, and a property costs a Python call each time.
    """

    #: byte 0
    command: int
    #: bits 7-5 of byte 0: the command specifier (ccs of a request, scs of a reply)
    specifier: int
    #: bytes 1-2 (LSB first) and 3: the object named (CiA 301 §7.2.4.3.3, §7.2.4.3.6);
    #: not ``index``, which a tuple already has
    object_index: int
    subindex: int
    #: bytes 1-3, the multiplexer, as sent (echoed in replies: KBX §8)
    mux: bytes
    #: bytes 4-7 as a little-endian number: size, abort code or expedited data
    word: int
    #: the eight bytes as received
    raw: bytes

    @property
    def expedited(self) -> bool:
        """Initiate frames: the e bit (bit 1), data in bytes 4-7 (CiA 301 §7.2.4.3.3)."""
        return bool(self.command & EXPEDITED)

    @property
    def size_indicated(self) -> bool:
        """Initiate frames: the s bit (bit 0): a size is given (CiA 301 §7.2.4.3.3)."""
        return bool(self.command & SIZE_INDICATED)

    @property
    def expedited_data(self) -> bytes:
        """An expedited initiate's data: 4 - n bytes when the size is indicated (n in bits
        3-2), else all four (CiA 301 §7.2.4.3.3, §7.2.4.3.6)."""
        return expedited_payload(self.command, self.raw)

    @property
    def size(self) -> int | None:
        """A segmented initiate's announced size (s set, e clear: bytes 4-7), else None."""
        return self.word if self.command & 0x03 == SIZE_INDICATED else None

    @property
    def toggle(self) -> int:
        """Segment frames: the toggle bit t, as its mask (0 or TOGGLE; CiA 301 §7.2.4.3.4)."""
        return self.command & TOGGLE

    @property
    def last(self) -> bool:
        """Segment frames: the c bit (bit 0): no more segments follow (CiA 301 §7.2.4.3.4)."""
        return bool(self.command & LAST_SEGMENT)

    @property
    def segment_data(self) -> bytes:
        """Segment frames: bytes 1-7 less the n unused ones (bits 3-1; CiA 301 §7.2.4.3.4)."""
        return segment_payload(self.raw)

    @property
    def is_abort(self) -> bool:
        """An abort transfer frame, either direction (CiA 301 §7.2.4.3.17: cs = 4)."""
        return self.specifier == CCS_ABORT

    @property
    def abort_code(self) -> AbortCode | int:
        """An abort frame's code (bytes 4-7), as an AbortCode where it is a known one."""
        return abort_code_of(self.raw)

    def answers_upload_of(self, mux: bytes) -> bool:
        """A reply that ends or opens the upload of ``mux``: an initiate upload response or an
        abort for that object (CiA 301 §7.2.4.3.6, §7.2.4.3.17)."""
        return self.mux == mux and self.specifier in _ANSWERS_UPLOAD


def parse_sdo(data: bytes) -> SdoFrame:
    """The SDO frame in ``data``: any eight bytes parse (CiA 301 §7.2.4.3: every SDO frame
    is eight bytes); any other length raises :class:`SdoFrameError`, the only error."""
    if data.__class__ is not bytes:  # bytes() of bytes costs more than this test
        data = bytes(data)
    if len(data) != 8:
        raise SdoFrameError(f"an SDO frame has 8 bytes, not {len(data)}")
    command, object_index, subindex, word = _SDO_LAYOUT.unpack(data)
    return _new_tuple(SdoFrame, (command, command >> 5, object_index, subindex, data[1:4], word,
                                 data))


def multiplexer(index: int, subindex: int) -> bytes:
    """The three bytes that name an object entry in an SDO frame: index LSB first, sub-index."""
    try:  # the packing checks the ranges (every SDO request comes this way)
        return _MULTIPLEXER.pack(index, subindex)
    except struct.error:
        if not 0 <= index <= 0xFFFF:
            raise ValueError(f"object index {index:#x} outside 0..0xFFFF") from None
        if not 0 <= subindex <= 0xFF:
            raise ValueError(f"sub-index {subindex:#x} outside 0..0xFF") from None
        raise


def split_multiplexer(mux: bytes) -> tuple[int, int]:
    """(index, sub-index) from the three multiplexer bytes."""
    index, subindex = _MULTIPLEXER.unpack_from(mux)
    return int(index), int(subindex)


def abort_data(mux: bytes, code: int) -> bytes:
    """An abort transfer frame's eight bytes (80h, multiplexer, code LSB first)."""
    return b"\x80" + mux + code.to_bytes(4, "little")


def expedited_upload_reply(mux: bytes, value: bytes) -> bytes:
    """The reply to an upload of a one- to four-byte value."""
    return bytes((EXPEDITED_UPLOAD_COMMAND[len(value)],)) + mux + value + ZEROS[len(value) : 4]


#: command byte -> where an expedited initiate frame's data ends: 4 - n bytes from byte 4 when
#: the size is indicated (n in bits 3-2), else all four (CiA 301 §7.2.4.3.3, §7.2.4.3.6). A
#: table: a client takes the value of every expedited reply with one lookup
EXPEDITED_END = tuple(8 - ((command >> 2) & 0x03) if command & SIZE_INDICATED else 8
                      for command in range(256))


def expedited_payload(command: int, data: bytes) -> bytes:
    """The data bytes of an expedited transfer: n bytes when the size is indicated, else four."""
    return data[4 : EXPEDITED_END[command]]


def segment_payload(data: bytes) -> bytes:
    """The data bytes of a segment frame: seven, minus the unused count in bits 3-1."""
    return data[1 : 8 - ((data[0] >> 1) & 0x07)]


def abort_code_of(data: bytes) -> AbortCode | int:
    """The abort code in an 80h frame, as an AbortCode where it is a known one."""
    code = int.from_bytes(data[4:8], "little")
    try:
        return AbortCode(code)
    except ValueError:
        return code
