"""The frames of any log ``blinkcan convert`` reads, each with its channel, streamed in blocks
of columns (:class:`~blinkcan.formats.columns.FrameColumns`).

python-can's formats and pcap come through blinkcan's reader,
:func:`blinkcan.formats.logs.read_messages` (which mends what python-can's readers misread:
ASC times stay absolute), their messages put in columns here; candump ``.log`` (plain, ``.gz``
or ``.zst``) is read straight into columns by ``formats/candump.py``. Any other
``.gz`` or ``.zst`` log is decompressed to a temporary file first (BLF and MF4 readers need to
seek; python-can's own ``.gz`` reading would bypass blinkcan's reader); memory stays bounded
either way.
"""

from __future__ import annotations

import gzip
import io
import os
import shutil
import tempfile
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import TYPE_CHECKING, BinaryIO, TextIO

from blinkcan.formats.candump import read_candump_columns
from blinkcan.formats.candump_columns import BLOCK_CHARS, read_plain_block
from blinkcan.formats.columns import FrameColumns
from blinkcan.formats.log_source import DecompressedText
from blinkcan.formats.logs import LogError, frame_kind, read_messages
from blinkcan.formats.unreadable import UnreadableLine

if TYPE_CHECKING:  # python-can loads where a log needs it: a candump log decodes without it
    import can

_CANDUMP = ".log"
#: frames per block of python-can's formats
BLOCK = 4096


def _suffixes(path: Path) -> tuple[str, str]:
    """(the format's suffix, the compression's: "", ".gz" or ".zst")."""
    suffixes = [s.lower() for s in path.suffixes]
    if suffixes and suffixes[-1] in (".gz", ".zst"):
        return (suffixes[-2] if len(suffixes) > 1 else ""), suffixes[-1]
    return (suffixes[-1] if suffixes else ""), ""


class _ZstdReader(io.RawIOBase):
    """A .zst file's bytes, frame after frame, that raises :class:`EOFError` where the file
    ends inside a frame: zstandard's ``stream_reader`` ends there as if the file were whole,
    so a log cut short would lose its tail silently."""

    def __init__(self, raw: BinaryIO) -> None:
        import zstandard  # noqa: PLC0415 (the [fleet] extra)

        self._raw, self._new = raw, zstandard.ZstdDecompressor().decompressobj
        self._frame, self._pending, self._started = self._new(), b"", False

    def readable(self) -> bool:
        return True

    def readinto(self, buffer: bytearray | memoryview) -> int:  # type: ignore[override]
        while not self._pending:
            if self._frame.eof:  # the next frame starts with what the last one left
                rest, self._frame, self._started = self._frame.unused_data, self._new(), False
                if rest:
                    self._started = True
                    self._pending = self._frame.decompress(rest)
                    continue
            chunk = self._raw.read(1 << 16)
            if not chunk:
                if self._started and not self._frame.eof:
                    raise EOFError("Compressed file ended before the end of its zstd frame")
                return 0
            self._started = True
            self._pending = self._frame.decompress(chunk)
        size = min(len(buffer), len(self._pending))
        buffer[:size] = self._pending[:size]
        self._pending = self._pending[size:]
        return size

    def close(self) -> None:
        self._raw.close()
        super().close()


def _zstd_text(path: Path) -> TextIO:
    reader = io.BufferedReader(_ZstdReader(path.open("rb")))
    return DecompressedText(reader, "utf-8", _BYTES_KEPT)


#: a byte that is not UTF-8 read as a surrogate escape: its line is unreadable, the others
#: of its block are read (formats/candump.py)
_BYTES_KEPT = "surrogateescape"


def _open_text(path: Path, compression: str) -> TextIO:
    if compression == ".gz":  # cut short: every line before the cut (formats/log_source.py)
        return DecompressedText(gzip.open(path, "rb"), "utf-8", _BYTES_KEPT)
    if compression == ".zst":
        return _zstd_text(path)
    return path.open(encoding="utf-8", errors=_BYTES_KEPT)


def _candump(path: Path, compression: str, arrow: bool, block_chars: int
             ) -> Iterator[FrameColumns]:
    with _open_text(path, compression) as stream:
        if arrow:  # a block of plain frames read whole (formats/candump_columns.py)
            yield from read_candump_columns(stream, read_plain_block, block_chars)
        else:
            yield from read_candump_columns(stream)


def message_columns(messages: Iterable[can.Message | UnreadableLine], block: int = BLOCK
                    ) -> Iterator[FrameColumns]:
    """python-can's messages (any format's reader) as blocks of ``block`` frames."""
    columns = FrameColumns()
    for message in messages:
        if isinstance(message, UnreadableLine):
            columns.add_unreadable(message)
            continue
        channel = None if message.channel is None else str(message.channel)
        if frame_kind(message) == "data":
            columns.times.append(message.timestamp)
            columns.channels.append(channel)
            columns.ids.append(message.arbitration_id)
            columns.extended.append(message.is_extended_id)
            columns.data.append(bytes(message.data))
        else:
            columns.add_other(message, channel)
        if len(columns) >= block:
            yield columns
            columns = FrameColumns()
    if columns.times:
        yield columns


def _decompressed(path: Path, suffix: str, compression: str) -> Iterator[FrameColumns]:
    handle, name = tempfile.mkstemp(suffix=suffix, prefix=".blinkcan-")
    try:
        with os.fdopen(handle, "wb") as target:
            if compression == ".gz":
                with gzip.open(path, "rb") as source:
                    shutil.copyfileobj(source, target)
            else:
                with _ZstdReader(path.open("rb")) as source:
                    shutil.copyfileobj(source, target)
        yield from message_columns(read_messages(Path(name), unreadable=True))
    finally:
        os.unlink(name)


def read_columns(path: str | os.PathLike[str], arrow: bool = True,
                 block_chars: int = BLOCK_CHARS) -> Iterator[FrameColumns]:
    """Every frame of a log file, in order, with its channel (None where the format has
    none), a block at a time. Raises :class:`LogError` (or the decompressor's error) for a
    file it cannot read. ``arrow``: a candump log's blocks (``block_chars`` characters) of
    plain frames are read whole (:class:`~blinkcan.formats.columns.ArrowColumns`); False
    reads every line on its own (the same frames: the tests compare both)."""
    source = Path(path)
    if not source.is_file():
        raise LogError(f"no such file: {source}")
    suffix, compression = _suffixes(source)
    if suffix == _CANDUMP:
        return _candump(source, compression, arrow, block_chars)
    if compression:
        return _decompressed(source, suffix, compression)
    return message_columns(read_messages(source, unreadable=True))
