"""pcap captures with the SocketCAN link type (LINKTYPE_CAN_SOCKETCAN, 227), which Wireshark and
tshark open and, with ``-d can.subdissector,canopen`` or the CANopen heuristics, dissect.

Our own few lines rather than a dependency: the format is a 24-byte file header and, per
frame, a 16-byte packet header plus the 16-byte ``struct can_frame`` (id big-endian with the
extended flag in bit 31, length, three padding bytes, eight data bytes). python-can writes no
pcap.
"""

from __future__ import annotations

import os
import struct
from collections.abc import Iterable, Iterator
from typing import BinaryIO

from blinkcan.protocol.frame import Frame

LINKTYPE_CAN_SOCKETCAN = 227
_HEADER = struct.Struct("<IHHiIII")
_PACKET = struct.Struct("<IIII")
_CAN = struct.Struct(">IB3x8s")
_MAGIC = 0xA1B2C3D4
_EXTENDED = 0x80000000


class PcapError(ValueError):
    """A file that is not a SocketCAN pcap capture."""


def write_pcap(stream: BinaryIO, frames: Iterable[tuple[float, Frame]]) -> int:
    """Write (timestamp, frame) pairs; returns how many."""
    stream.write(_HEADER.pack(_MAGIC, 2, 4, 0, 0, 65535, LINKTYPE_CAN_SOCKETCAN))
    count = 0
    for timestamp, frame in frames:
        seconds = int(timestamp)
        micros = round((timestamp - seconds) * 1_000_000)
        if micros >= 1_000_000:
            seconds, micros = seconds + 1, micros - 1_000_000
        can_id = frame.can_id | (_EXTENDED if frame.extended else 0)
        record = _CAN.pack(can_id, len(frame.data), frame.data.ljust(8, b"\x00"))
        stream.write(_PACKET.pack(seconds, micros, len(record), len(record)) + record)
        count += 1
    return count


def read_pcap(stream: BinaryIO) -> Iterator[tuple[float, Frame]]:
    header = stream.read(_HEADER.size)
    if len(header) < _HEADER.size:
        raise PcapError("too short for a pcap file")
    magic, _, _, _, _, _, linktype = _HEADER.unpack(header)
    if magic != _MAGIC:
        raise PcapError(f"not a little-endian microsecond pcap file (magic {magic:08X}h)")
    if linktype != LINKTYPE_CAN_SOCKETCAN:
        raise PcapError(f"link type {linktype}, not SocketCAN ({LINKTYPE_CAN_SOCKETCAN})")
    while packet := stream.read(_PACKET.size):
        if len(packet) < _PACKET.size:
            raise PcapError("truncated packet header")
        seconds, micros, included, _ = _PACKET.unpack(packet)
        record = stream.read(included)
        if len(record) < _CAN.size:
            raise PcapError("truncated CAN frame")
        can_id, length, data = _CAN.unpack(record[: _CAN.size])
        extended = bool(can_id & _EXTENDED)
        yield seconds + micros / 1_000_000, Frame(can_id & 0x1FFFFFFF, data[: min(length, 8)],
                                                  extended)


def is_pcap(path: str | os.PathLike[str]) -> bool:
    return str(path).lower().endswith((".pcap", ".cap"))
