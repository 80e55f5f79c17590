"""SDO frame layout shared by the server and client state machines (CiA 301 §7.2.4.3).

Every SDO frame is eight bytes: a command byte, the multiplexer (index LSB first, then
sub-index; KBX §8 "Every answer has index and sub index echo") and four data bytes.
"""

from __future__ import annotations

import struct

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

#: Expedited upload reply command by value length: PKP §15 4Bh (2 bytes), §26 43h (4), §32 4Fh (1).
EXPEDITED_UPLOAD_COMMAND = {1: 0x4F, 2: 0x4B, 3: 0x47, 4: 0x43}
#: Expedited download request command by value length: PKP §16 2Bh, §18 2Fh, KBX §28 23h.
EXPEDITED_DOWNLOAD_COMMAND = {1: 0x2F, 2: 0x2B, 3: 0x27, 4: 0x23}

ZEROS = b"\x00" * 8
_MULTIPLEXER = struct.Struct("<HB")


def multiplexer(index: int, subindex: int) -> bytes:
    """The three bytes that name an object entry in an SDO frame: index LSB first, sub-index."""
    if not 0 <= index <= 0xFFFF:
        raise ValueError(f"object index {index:#x} outside 0..0xFFFF")
    if not 0 <= subindex <= 0xFF:
        raise ValueError(f"sub-index {subindex:#x} outside 0..0xFF")
    return _MULTIPLEXER.pack(index, subindex)


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


def expedited_payload(command: int, data: bytes) -> bytes:
    """The data bytes of an expedited transfer: n bytes when the size is indicated, else four."""
    if command & 0x01:
        return data[4 : 8 - ((command >> 2) & 0x03)]
    return data[4:8]


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
