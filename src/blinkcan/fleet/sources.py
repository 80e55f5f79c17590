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
from typing import TYPE_CHECKING, BinaryIO, TextIO, cast

from blinkcan.formats.candump import read_candump_columns
from blinkcan.formats.columns import FrameColumns
from blinkcan.formats.logs import LogError, frame_kind, read_messages

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


def _candump(path: Path, compression: str) -> Iterator[FrameColumns]:
    with _open_text(path, compression) as stream:
        yield from read_candump_columns(stream)


def message_columns(messages: Iterable[can.Message], block: int = BLOCK
                    ) -> Iterator[FrameColumns]:
    """python-can's messages (any format's reader) as blocks of ``block`` frames."""
    columns = FrameColumns()
    for message in messages:
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
                import zstandard  # noqa: PLC0415 (the [fleet] extra)

                with path.open("rb") as raw:
                    shutil.copyfileobj(zstandard.ZstdDecompressor().stream_reader(raw), target)
        yield from message_columns(read_messages(Path(name)))
    finally:
        os.unlink(name)


def read_columns(path: str | os.PathLike[str]) -> Iterator[FrameColumns]:
    """Every frame of a log file, in order, with its channel (None where the format has
    none), a block at a time. Raises :class:`LogError` (or the decompressor's error) for a
    file it cannot read."""
    source = Path(path)
    if not source.is_file():
        raise LogError(f"no such file: {source}")
    suffix, compression = _suffixes(source)
    if suffix == _CANDUMP:
        return _candump(source, compression)
    if compression:
        return _decompressed(source, suffix, compression)
    return message_columns(read_messages(source))
