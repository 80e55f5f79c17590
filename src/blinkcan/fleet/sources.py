"""The frames of any log ``blinkcan convert`` reads, each with its channel, streamed in blocks
of columns (:class:`~blinkcan.formats.columns.FrameColumns`).

python-can's formats and pcap come through blinkcan's reader,
:func:`blinkcan.formats.logs.read_messages` (which mends what python-can's readers misread:
ASC times stay absolute), their messages put in columns here; candump ``.log`` (plain, ``.gz``
or ``.zst``) is read straight into columns by ``formats/candump.py``. Any other
``.gz`` or ``.zst`` log is decompressed to a temporary file first (BLF and MF4 readers need to
seek; python-can's own ``.gz`` reading would bypass blinkcan's reader), up to
:data:`MAX_DECOMPRESSED` bytes, in the run's attempt folder (recovery removes it where a run
was killed); memory stays bounded either way.
"""

from __future__ import annotations

import gzip
import io
import os
import stat
import tempfile
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path
from typing import TYPE_CHECKING, BinaryIO, TextIO

from blinkcan.formats.candump import read_candump_columns
from blinkcan.formats.candump_columns import BLOCK_CHARS, read_plain_block
from blinkcan.formats.columns import FrameColumns
from blinkcan.formats.compressed import READ_SIZE, ZstdReader
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


def _zstd_text(path: Path) -> TextIO:
    reader = io.BufferedReader(ZstdReader(path))
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
            columns.add_frame(message.timestamp, channel, message.arbitration_id,
                              message.is_extended_id, bytes(message.data))
        else:
            columns.add_other(message, channel)
        if len(columns) >= block:
            yield columns
            columns = FrameColumns()
    if columns.times:
        yield columns


#: the most bytes a non-candump compressed log is decompressed to (on disk, to be read)
MAX_DECOMPRESSED = 64 << 30


def _copy_bounded(read: Callable[[int], bytes | None], target: BinaryIO, path: Path,
                  limit: int) -> None:
    copied = 0
    while chunk := read(READ_SIZE):
        copied += len(chunk)
        if copied > limit:
            raise LogError(f"{path} decompresses to over {limit:,} bytes, the most a "
                           "compressed log other than candump is decompressed to (on disk, "
                           "to be read): refused")
        target.write(chunk)


def _decompressed(path: Path, suffix: str, compression: str, scratch: str | None,
                  limit: int) -> Iterator[FrameColumns]:
    """``path`` decompressed into a file in ``scratch`` (the run's attempt folder, which
    recovery removes where the run is killed; else the system's temporary folder)."""
    if scratch is not None:
        os.makedirs(scratch, exist_ok=True)
    handle, name = tempfile.mkstemp(suffix=suffix, prefix=".blinkcan-", dir=scratch)
    try:
        with os.fdopen(handle, "wb") as target:
            if compression == ".gz":
                with gzip.open(path, "rb") as source:
                    _copy_bounded(source.read, target, path, limit)
            else:
                with ZstdReader(path) as source:
                    _copy_bounded(source.read, target, path, limit)
        yield from message_columns(read_messages(Path(name), unreadable=True))
    finally:
        os.unlink(name)


#: what a file that is not a regular one is
_NOT_REGULAR = ((stat.S_ISDIR, "a folder"), (stat.S_ISFIFO, "a FIFO"),
                (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"),
                (stat.S_ISSOCK, "a socket"))


def _check_regular(source: Path) -> None:
    """:class:`LogError` unless ``source`` is a regular file: a dataset's file is read whole
    and read again when it changes, which a stream cannot be."""
    try:
        mode = source.stat().st_mode
    except FileNotFoundError:
        raise LogError(f"no such file: {source}") from None
    except OSError as error:
        raise LogError(f"cannot read {source}: {error.strerror}") from None
    if not stat.S_ISREG(mode):
        what = next((name for test, name in _NOT_REGULAR if test(mode)), "not a regular file")
        raise LogError(f"{source} is {what}: --parquet reads regular files only "
                       "(decode without --parquet reads a stream)")


def read_columns(path: str | os.PathLike[str], arrow: bool = True,
                 block_chars: int = BLOCK_CHARS, scratch: str | None = None,
                 max_decompressed: int = MAX_DECOMPRESSED) -> Iterator[FrameColumns]:
    """Every frame of a log file, in order, with its channel (None where the format has
    none), a block at a time. Raises :class:`LogError` (or the decompressor's error) for a
    file it cannot read. ``arrow``: a candump log's blocks (``block_chars`` characters) of
    plain frames are read whole (:class:`~blinkcan.formats.columns.ArrowColumns`); False
    reads every line on its own (the same frames: the tests compare both). A compressed log
    other than candump is decompressed into a file in ``scratch`` (None: the system's
    temporary folder), up to ``max_decompressed`` bytes (past that: :class:`LogError`)."""
    source = Path(path)
    _check_regular(source)
    suffix, compression = _suffixes(source)
    if suffix == _CANDUMP:
        return _candump(source, compression, arrow, block_chars)
    if compression:
        return _decompressed(source, suffix, compression, scratch, max_decompressed)
    return message_columns(read_messages(source, unreadable=True))
