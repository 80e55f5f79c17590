"""Compressed logs read as they are decompressed, a bounded buffer at a time: ``.gz`` with the
standard library, ``.zst`` with zstandard (in blinkcan's [fleet] extra; without it, one
:class:`MissingExtraError` naming the extra). A ``.zst`` file cut inside a frame raises
:class:`EOFError` at its end, as ``gzip`` does, so a reader that keeps the lines before a cut
(formats/log_source.py) says the log was cut short instead of losing its tail silently."""

from __future__ import annotations

import gzip
import io
import os
from pathlib import Path
from typing import BinaryIO

from blinkcan.formats.log_source import LogError

#: the compressions read, by suffix
COMPRESSIONS = (".gz", ".zst")
#: a skippable frame's 16 magic numbers (RFC 8878 §3.1.2)
_SKIPPABLE = range(0x184D2A50, 0x184D2A60)
#: the longest frame header: magic, descriptor, window, dictionary id, content size (§3.1.1.1)
_HEADER_MAX = 18
#: compressed bytes read at a time, and decompressed bytes given at most per read: a file
#: holding gigabytes of zeros in a few kilobytes is read a buffer at a time
READ_SIZE = 1 << 16


class MissingExtraError(LogError):
    """A log that needs an optional module which is not installed; ``extra`` is blinkcan's
    extra that installs it."""

    def __init__(self, message: str, extra: str) -> None:
        super().__init__(message)
        self.extra = extra


def ends_with_a_frame(raw: BinaryIO) -> bool:
    """Whether the .zst file ``raw`` ends where a frame does: its frames' headers and block
    headers walked, the blocks skipped (RFC 8878 §3.1.1: a block header gives the block's
    size and whether it is the frame's last; a checksum of 4 bytes may follow)."""
    import zstandard  # noqa: PLC0415 (the [fleet] extra)

    size = raw.seek(0, os.SEEK_END)
    position = 0
    while position < size:
        raw.seek(position)
        header = raw.read(_HEADER_MAX)
        magic = int.from_bytes(header[:4], "little")
        if magic in _SKIPPABLE:  # §3.1.2: magic, 4 bytes of size, the skipped bytes
            position += 8 + int.from_bytes(header[4:8], "little")
            continue
        try:
            position += zstandard.frame_header_size(header)
            checksum = zstandard.get_frame_parameters(header).has_checksum
        except zstandard.ZstdError:
            return False
        last = False
        while not last and position < size:  # §3.1.1.2: 3 bytes, little-endian
            raw.seek(position)
            block = int.from_bytes(raw.read(3), "little")
            last, kind, length = bool(block & 1), block >> 1 & 3, block >> 3
            position += 3 + (1 if kind == 1 else length)  # an RLE block holds one byte
        if not last:
            return False
        position += 4 if checksum else 0
    return position == size


class ZstdReader(io.RawIOBase):
    """A .zst file's bytes, frame after frame, a bounded buffer at a time (zstandard's
    ``stream_reader``), that raises :class:`EOFError` where the file ends inside a frame: the
    stream reader ends there as if the file were whole, so a log cut short would lose its
    tail silently. ``tell`` counts the bytes given (python-can's BLF reader names a corrupt
    container by it)."""

    def __init__(self, path: Path) -> None:
        import zstandard  # noqa: PLC0415 (the [fleet] extra)

        self._raw = path.open("rb")
        self._stream = zstandard.ZstdDecompressor().stream_reader(
            self._raw, read_size=READ_SIZE, read_across_frames=True, closefd=False)
        self._checked = False
        self._given = 0

    def readable(self) -> bool:
        return True

    def tell(self) -> int:
        return self._given

    def readinto(self, buffer: bytearray | memoryview) -> int:  # type: ignore[override]
        view = memoryview(buffer)[:READ_SIZE]
        size = self._stream.readinto(view)
        if not size and view.nbytes and not self._checked:
            self._checked = True  # once: the file's end is read again after an error
            if not ends_with_a_frame(self._raw):
                raise EOFError("Compressed file ended before the end of its zstd frame")
        self._given += size
        return size

    def close(self) -> None:
        self._stream.close()  # type: ignore[no-untyped-call]  # zstandard types it so
        self._raw.close()
        super().close()


def check_zstandard(path: object) -> None:
    """:class:`MissingExtraError` when zstandard, which reads ``path``, is not installed."""
    try:
        import zstandard  # noqa: F401, PLC0415 (the [fleet] extra)
    except ImportError:
        raise MissingExtraError(f"{path}: a .zst log is read with zstandard, which is not "
                                "installed: it comes with blinkcan's [fleet] extra",
                                "fleet") from None


def open_decompressed(path: Path, compression: str) -> io.BufferedIOBase:
    """``path``'s bytes decompressed as they are read (``compression``: ".gz" or ".zst")."""
    if compression == ".gz":
        return gzip.open(path, "rb")
    check_zstandard(path)
    return io.BufferedReader(ZstdReader(path), READ_SIZE)
