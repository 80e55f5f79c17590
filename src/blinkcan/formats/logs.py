"""Frames from and to files: every log format python-can reads and writes (ASC, BLF, candump,
TRC, CSV, SQLite, MF4 with python-can's extra), and pcap with the SocketCAN link type."""

from __future__ import annotations

import io
import os
import struct
from collections.abc import Iterator
from pathlib import Path
from types import TracebackType

import can

from blinkcan.formats.atomic import write_atomically
from blinkcan.formats.pcap import PcapError, is_pcap, read_pcap, write_pcap
from blinkcan.protocol.frame import Frame
from blinkcan.runtime.canbus import to_message


class LogError(ValueError):
    """A file that cannot be read or written as a CAN log."""


def read_frames(path: str | os.PathLike[str]) -> Iterator[tuple[float, Frame]]:
    """(timestamp, frame) pairs of a log file; error and remote frames are skipped."""
    source = Path(path)
    if not source.is_file():
        raise LogError(f"no such file: {source}")
    if is_pcap(source):
        with source.open("rb") as stream:
            try:
                yield from read_pcap(stream)
            except PcapError as error:
                raise LogError(f"{source}: {error}") from None
        return
    try:
        reader = can.LogReader(str(source))
    except ValueError as error:
        raise LogError(f"{source}: {error}") from None
    trusted = Frame.trusted  # python-can parsed and checked the frames
    with reader:
        try:
            for message in reader:
                if message.is_error_frame or message.is_remote_frame or message.dlc > 8:
                    continue  # as runtime.to_frame: data frames of classic CAN only
                yield message.timestamp, trusted(message.arbitration_id, bytes(message.data),
                                                 message.is_extended_id)
        except (ValueError, IndexError, struct.error, UnicodeDecodeError) as error:
            raise LogError(f"{source}: not a readable log ({error})") from None


class FrameWriter:
    """Write frames to ``path`` in the format its name says (.pcap, or python-can's formats).

    Atomic: python-can's formats go to a temporary file of the same suffix beside the target,
    renamed over it when complete; an existing file is refused unless ``replace`` is set."""

    def __init__(self, path: str | os.PathLike[str], replace: bool = False) -> None:
        self.path = Path(path)
        if self.path.exists() and not replace:
            raise LogError(f"{self.path} exists; pass --force to replace it")
        self._pcap: list[tuple[float, Frame]] | None = [] if is_pcap(self.path) else None
        self._logger: can.Listener | None = None
        self._partial = self.path.with_name(f".{self.path.stem}.partial{self.path.suffix}")
        if self._pcap is None:
            try:
                self._logger = can.Logger(str(self._partial))
            except ValueError as error:
                raise LogError(f"{self.path}: {error}") from None
        self.count = 0

    def write(self, timestamp: float, frame: Frame) -> None:
        self.count += 1
        if self._pcap is not None:
            self._pcap.append((timestamp, frame))
        else:
            assert self._logger is not None
            self._logger.on_message_received(to_message(frame, timestamp))

    def close(self) -> None:
        if self._pcap is not None:
            buffer = io.BytesIO()
            write_pcap(buffer, self._pcap)
            write_atomically(self.path, buffer.getvalue())
        elif self._logger is not None:
            self._logger.stop()
            os.replace(self._partial, self.path)

    def __enter__(self) -> FrameWriter:
        return self

    def __exit__(self, kind: type[BaseException] | None, error: BaseException | None,
                 trace: TracebackType | None) -> None:
        if error is None:
            self.close()
            return
        # the writing failed: leave the target as it was, and no partial file behind
        if self._logger is not None:
            self._logger.stop()
            self._partial.unlink(missing_ok=True)
