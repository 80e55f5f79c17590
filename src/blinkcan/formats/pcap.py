"""pcap captures with the SocketCAN link type (LINKTYPE_CAN_SOCKETCAN, 227), which Wireshark and
tshark open and, with ``-d can.subdissector,canopen`` or the CANopen heuristics, dissect.

Our own few lines rather than a dependency: the format is a 24-byte file header and, per
frame, a 16-byte packet header plus the SocketCAN frame: ``struct can_frame`` (16 bytes: id
big-endian with the flags in bits 29-31, length, three padding bytes, eight data bytes) or
``struct canfd_frame`` (72 bytes, 64 data bytes, flags byte with CANFD_FDF). Remote and error
frames are carried as SocketCAN does (CAN_RTR_FLAG, CAN_ERR_FLAG with the error class in the
id, ``linux/can.h``, ``linux/can/error.h``). python-can writes no pcap.

Reading never trusts a length: a packet longer than a CAN FD frame, a standard identifier over
7FFh or a truncated file is named by its packet's number (:func:`pcap_items`: an unreadable
packet in its place, the frames around it read; :func:`read_pcap_messages`: a
:class:`PcapError`), and memory stays bounded by one frame whatever the file says.
"""

from __future__ import annotations

import os
import struct
from collections.abc import Iterable, Iterator
from typing import BinaryIO

import can

from blinkcan.errors import BlinkcanError
from blinkcan.formats.unreadable import UnreadableLine
from blinkcan.protocol.frame import Frame

LINKTYPE_CAN_SOCKETCAN = 227
_HEADER = struct.Struct("<IHHiIII")
_PACKET = struct.Struct("<IIII")
#: the last second a packet header's unsigned 32-bit seconds field holds (in 2106)
_LAST_SECOND = 0xFFFFFFFF
_CAN = struct.Struct(">IBB2x8s")
_CANFD = struct.Struct(">IBB2x64s")
_MAGIC_MICRO, _MAGIC_NANO = 0xA1B2C3D4, 0xA1B23C4D
_SNAPLEN = 65535
# linux/can.h
CAN_EFF_FLAG, CAN_RTR_FLAG, CAN_ERR_FLAG = 0x80000000, 0x40000000, 0x20000000
CAN_EFF_MASK, CAN_SFF_MASK = 0x1FFFFFFF, 0x7FF
CANFD_BRS, CANFD_ESI, CANFD_FDF = 0x01, 0x02, 0x04
CAN_ERR_DLC = 8


class PcapError(BlinkcanError, ValueError):
    """A file that is not a SocketCAN pcap capture."""


def encode_record(message: can.Message) -> bytes:
    """The SocketCAN bytes of one message: data, remote, error or CAN FD frame."""
    if message.is_error_frame:
        can_id = CAN_ERR_FLAG | (message.arbitration_id & CAN_EFF_MASK)
        data = bytes(message.data[:CAN_ERR_DLC])  # SocketCAN's have 8; a log's may have none
        return _CAN.pack(can_id, len(data), 0, data.ljust(8, b"\x00"))
    can_id = message.arbitration_id | (CAN_EFF_FLAG if message.is_extended_id else 0)
    if message.is_remote_frame:
        return _CAN.pack(can_id | CAN_RTR_FLAG, message.dlc, 0, bytes(8))
    data = bytes(message.data[:64])
    if message.is_fd or len(data) > 8:  # more than 8 bytes only fit a CAN FD frame
        flags = CANFD_FDF | (CANFD_BRS if message.bitrate_switch else 0) | (
            CANFD_ESI if message.error_state_indicator else 0)
        return _CANFD.pack(can_id, len(data), flags, data.ljust(64, b"\x00"))
    return _CAN.pack(can_id, len(data), 0, data.ljust(8, b"\x00"))


class PcapWriter:
    """Streams messages to a binary stream as they come: header first, then one packet each."""

    def __init__(self, stream: BinaryIO) -> None:
        self._stream = stream
        stream.write(_HEADER.pack(_MAGIC_MICRO, 2, 4, 0, 0, _SNAPLEN, LINKTYPE_CAN_SOCKETCAN))
        self.count = 0

    def write(self, message: can.Message) -> None:
        """One packet; a time pcap cannot hold (before 1970, after 2106: its seconds are an
        unsigned 32-bit field) is a :class:`PcapError` and nothing is written."""
        timestamp = message.timestamp
        if not 0 <= timestamp < _LAST_SECOND:
            raise PcapError(f"a pcap packet's time is 0..{_LAST_SECOND - 1} s since 1970, not "
                            f"{timestamp!r}: frame {message.arbitration_id:X}h cannot be "
                            "written")
        seconds = int(timestamp)
        micros = round((timestamp - seconds) * 1_000_000)
        if micros >= 1_000_000:
            seconds, micros = seconds + 1, micros - 1_000_000
        record = encode_record(message)
        self._stream.write(_PACKET.pack(seconds, micros, len(record), len(record)) + record)
        self.count += 1


def _message(number: int, timestamp: float, record: bytes) -> can.Message:
    can_id, length, flags = struct.unpack_from(">IBB", record)
    fd = len(record) >= _CANFD.size or bool(flags & CANFD_FDF)
    data_area = record[8:]
    if can_id & CAN_ERR_FLAG:
        return can.Message(timestamp=timestamp, is_error_frame=True,
                           arbitration_id=can_id & CAN_EFF_MASK,
                           data=data_area[: min(length, CAN_ERR_DLC)], check=False)
    extended = bool(can_id & CAN_EFF_FLAG)
    ident = can_id & CAN_EFF_MASK
    if not extended and ident > CAN_SFF_MASK:
        raise PcapError(f"packet {number}: standard identifier {ident:X}h is over 7FFh")
    if can_id & CAN_RTR_FLAG:
        return can.Message(timestamp=timestamp, arbitration_id=ident, is_extended_id=extended,
                           is_remote_frame=True, dlc=min(length, 8))
    limit = 64 if fd else 8
    if length > limit:
        raise PcapError(f"packet {number}: length {length} over {limit} bytes")
    return can.Message(timestamp=timestamp, arbitration_id=ident, is_extended_id=extended,
                       data=data_area[:length], is_fd=fd,
                       bitrate_switch=bool(flags & CANFD_BRS),
                       error_state_indicator=bool(flags & CANFD_ESI))


def read_pcap_messages(stream: BinaryIO) -> Iterator[can.Message]:
    """Every frame of a SocketCAN capture, remote, error and CAN FD frames included; a packet
    that is no frame raises :class:`PcapError` naming it."""
    for item in pcap_items(stream):
        if isinstance(item, UnreadableLine):
            raise PcapError(f"packet {item.number}: {item.reason}")
        yield item


def pcap_items(stream: BinaryIO) -> Iterator[can.Message | UnreadableLine]:
    """Every frame of a SocketCAN capture, a packet that is no frame an
    :class:`~blinkcan.formats.unreadable.UnreadableLine` (``unit`` "packet", its bytes in hex
    as its text) in its place (issue 23: one bad packet does not cost the capture). A packet
    whose frame says what no frame is (a standard identifier over 7FFh, more data than its
    kind carries) is passed over: the next starts where its length says. One whose length is
    no SocketCAN frame's ends the reading (the packets after it cannot be found), as does
    one cut off at the end (a capture killed mid-write). A file that is no SocketCAN capture
    (its header) raises :class:`PcapError`, and so does one none of whose packets is a frame."""
    header = stream.read(_HEADER.size)
    if len(header) < _HEADER.size:
        raise PcapError("too short for a pcap file")
    magic, _, _, _, _, _, linktype = _HEADER.unpack(header)
    if magic not in (_MAGIC_MICRO, _MAGIC_NANO):
        raise PcapError(f"not a little-endian pcap file (magic {magic:08X}h)")
    if linktype != LINKTYPE_CAN_SOCKETCAN:
        raise PcapError(f"link type {linktype}, not SocketCAN ({LINKTYPE_CAN_SOCKETCAN})")
    scale = 1e-9 if magic == _MAGIC_NANO else 1e-6
    frames = 0
    first: UnreadableLine | None = None
    for item in _packets(stream, scale):
        if isinstance(item, UnreadableLine):
            first = first or item
        else:
            frames += 1
        yield item
    if first is not None and not frames:
        raise PcapError(f"no packet is a CAN frame ({first})")


def _packets(stream: BinaryIO, scale: float) -> Iterator[can.Message | UnreadableLine]:
    """The packets after the file's header (:func:`pcap_items`)."""
    number = 0
    while packet := stream.read(_PACKET.size):
        number += 1
        if len(packet) < _PACKET.size:
            yield _unreadable(number, packet, "truncated header", None, cut_off=True)
            break
        seconds, fraction, included, _ = _PACKET.unpack(packet)
        time = seconds + fraction * scale
        if not _CAN.size <= included <= _CANFD.size:  # bounded: never read what a file claims
            yield _unreadable(number, packet, f"{included} bytes, not a SocketCAN frame "
                              f"({_CAN.size}..{_CANFD.size}): the packets after it cannot be "
                              "found", time)
            break
        record = stream.read(included)
        if len(record) < included:
            yield _unreadable(number, packet + record, "truncated CAN frame", time,
                              cut_off=True)
            break
        try:
            message = _message(number, time, record)
        except PcapError as error:
            yield _unreadable(number, packet + record, str(error).partition(": ")[2], time)
            continue
        yield message


def _unreadable(number: int, data: bytes, reason: str, time: float | None,
                cut_off: bool = False) -> UnreadableLine:
    return UnreadableLine(number, data.hex(), reason, time, cut_off, "packet")


def write_pcap(stream: BinaryIO, frames: Iterable[tuple[float, Frame]]) -> int:
    """Write (timestamp, data frame) pairs; returns how many."""
    writer = PcapWriter(stream)
    for timestamp, frame in frames:
        writer.write(can.Message(timestamp=timestamp, arbitration_id=frame.can_id,
                                 data=frame.data, is_extended_id=frame.extended, check=False))
    return writer.count


def read_pcap(stream: BinaryIO) -> Iterator[tuple[float, Frame]]:
    """(timestamp, frame) of the classic data frames of a capture."""
    for message in read_pcap_messages(stream):
        if not (message.is_error_frame or message.is_remote_frame or message.is_fd):
            yield message.timestamp, Frame.trusted(message.arbitration_id, bytes(message.data),
                                                   message.is_extended_id)


def is_pcap(path: str | os.PathLike[str]) -> bool:
    return str(path).lower().endswith((".pcap", ".cap"))
