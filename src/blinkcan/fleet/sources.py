"""The frames of any log ``blinkcan convert`` reads, each with its channel, streamed.

python-can's formats and pcap come through blinkcan's reader,
:func:`blinkcan.formats.logs.read_messages` (which mends what python-can's readers misread:
ASC times stay absolute); candump ``.log`` (plain, ``.gz`` or ``.zst``) through the fast reader
of ``formats/candump.py``, the channel taken from each line as the reader passes it. Any other
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
from collections.abc import Iterator
from pathlib import Path
from typing import BinaryIO, TextIO, cast

import can

from blinkcan.formats.candump import read_candump_lines
from blinkcan.formats.log_source import bounded_lines
from blinkcan.formats.logs import LogError, frame_kind, read_messages
from blinkcan.protocol.frame import Frame

#: (timestamp, a Frame for a classic data frame or the message for any other, channel)
Item = tuple[float, "Frame | can.Message", "str | None"]
_CANDUMP = ".log"


def _suffixes(path: Path) -> tuple[str, str]:
    """(the format's suffix, the compression's: "", ".gz" or ".zst")."""
    suffixes = [s.lower() for s in path.suffixes]
    if suffixes and suffixes[-1] in (".gz", ".zst"):
        return (suffixes[-2] if len(suffixes) > 1 else ""), suffixes[-1]
    return (suffixes[-1] if suffixes else ""), ""


class _ChannelLines:
    """The lines of a candump log, remembering the channel of the line last read: the reader
    pulls one line per frame it yields, so that is the frame's channel."""

    def __init__(self, lines: TextIO) -> None:
        self._lines = lines
        self.channel: str | None = None

    def __iter__(self) -> Iterator[str]:
        for line in bounded_lines(self._lines, "candump"):  # never a whole file as one line
            fields = line.split(None, 2)
            self.channel = fields[1] if len(fields) > 1 else None
            yield line


def _zstd_text(path: Path) -> TextIO:
    import zstandard  # noqa: PLC0415 (the [fleet] extra)

    raw = path.open("rb")
    reader = zstandard.ZstdDecompressor().stream_reader(raw, closefd=True)
    return io.TextIOWrapper(cast(BinaryIO, reader), encoding="utf-8")


def _open_text(path: Path, compression: str) -> TextIO:
    if compression == ".gz":
        return gzip.open(path, "rt", encoding="utf-8")
    if compression == ".zst":
        return _zstd_text(path)
    return path.open(encoding="utf-8")


def _candump(path: Path, compression: str) -> Iterator[Item]:
    with _open_text(path, compression) as stream:
        lines = _ChannelLines(stream)
        for timestamp, item in read_candump_lines(lines):
            yield timestamp, item, lines.channel


def _messages(path: Path) -> Iterator[Item]:
    trusted = Frame.trusted  # python-can (or the pcap reader) parsed and checked the frame
    for message in read_messages(path):
        channel = None if message.channel is None else str(message.channel)
        if frame_kind(message) == "data":
            yield message.timestamp, trusted(message.arbitration_id, bytes(message.data),
                                             message.is_extended_id), channel
        else:
            yield message.timestamp, message, channel


def _decompressed(path: Path, suffix: str, compression: str) -> Iterator[Item]:
    handle, name = tempfile.mkstemp(suffix=suffix, prefix=".blinkcan-")
    try:
        with os.fdopen(handle, "wb") as target:
            if compression == ".gz":
                with gzip.open(path, "rb") as source:
                    shutil.copyfileobj(source, target)
            else:
                import zstandard  # noqa: PLC0415 (the [fleet] extra)

                with path.open("rb") as raw:
                    shutil.copyfileobj(zstandard.ZstdDecompressor().stream_reader(raw), target)
        yield from _messages(Path(name))
    finally:
        os.unlink(name)


def read_items(path: str | os.PathLike[str]) -> Iterator[Item]:
    """Every frame of a log file, in order, with its channel (None where the format has
    none). Raises :class:`LogError` (or the decompressor's error) for a file it cannot read."""
    source = Path(path)
    if not source.is_file():
        raise LogError(f"no such file: {source}")
    suffix, compression = _suffixes(source)
    if suffix == _CANDUMP:
        return _candump(source, compression)
    if compression:
        return _decompressed(source, suffix, compression)
    return _messages(source)
