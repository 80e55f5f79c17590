"""A block of candump ``-L`` lines read whole by Arrow, where every line is a plain data frame.

The fleet reads a log half a megabyte at a time (:data:`BLOCK_CHARS`). Most blocks of a logger's
capture are nothing but lines like ``(1700000000.000500) can0 18FEF100#FFFF``: one
vectorised regex (:data:`ORDINARY`) checks that every line of the block is one, and Arrow
splits them into columns (times cast by Arrow, identifiers read once per distinct text, the
data's hex digits turned into bytes by a table lookup over the whole block), about a
microsecond a frame less than reading each line in Python. Any other block (a comment, a
blank line, a remote, CAN FD or error frame, a direction field, an odd line) is read line by
line by ``formats/candump.py`` as always, so what a log reads as (unreadable lines and their
numbers included) does not depend on the path: a line the pattern takes is one that reader
reads as the same classic data frame (same time, channel, identifier, flag and bytes).
"""

from __future__ import annotations

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc

from blinkcan.formats.columns import ArrowColumns

#: characters read at a time (half a megabyte, some 11,000 lines): Arrow's calls cost per
#: block, not per line
BLOCK_CHARS = 1 << 19
#: a plain data frame as formats/candump.py reads it: a time of digits (at most 12 before
#: the point and 9 after: always finite), one channel word, 3 hex digits up to 7FFh or 8 up
#: to 1FFFFFFFh (no error flag), then 0 to 8 bytes; single spaces, nothing else
ORDINARY = (r"^\(\d{1,12}\.\d{1,9}\) [!-~]+ (?:[0-7][0-9A-Fa-f]{2}|[01][0-9A-Fa-f]{7})"
            r"#(?:[0-9A-Fa-f]{2}){0,8}$")
_STANDARD_DIGITS = 3


def _hex_values() -> np.ndarray:
    """Each hex digit's value by its ASCII code."""
    values = np.zeros(256, np.uint8)
    for digits, base in ((b"0123456789", 0), (b"abcdef", 10), (b"ABCDEF", 10)):
        for offset, code in enumerate(digits):
            values[code] = base + offset
    return values


_HEX_VALUES = _hex_values()


def _every(parts: pa.Array, count: int, first: int) -> pa.Array:
    """Items ``first``, ``first + count``, ... of a flattened list of ``count`` per line."""
    return parts.take(pa.array(np.arange(first, len(parts), count, dtype=np.int64)))


def _hex_bytes(digits: pa.StringArray) -> pa.BinaryArray:
    """Strings of an even count of hex digits as their bytes (``bytes.fromhex`` of each)."""
    size = len(digits)
    _, offset_buffer, text_buffer = digits.buffers()
    offsets = np.frombuffer(offset_buffer, np.int32)[digits.offset:digits.offset + size + 1]
    text = np.frombuffer(text_buffer if text_buffer is not None else b"",
                         np.uint8)[offsets[0]:offsets[-1]]
    nibbles = _HEX_VALUES[text]
    data = (nibbles[0::2] << 4) | nibbles[1::2]
    starts = ((offsets - offsets[0]) // 2).astype(np.int32)
    return pa.Array.from_buffers(pa.binary(), size,
                                 [None, pa.py_buffer(starts), pa.py_buffer(data)])


def read_plain_block(lines: list[str]) -> ArrowColumns | None:
    """The block's frames as Arrow columns when every line is a plain data frame
    (:data:`ORDINARY`); None otherwise (an empty block too): then read it line by line."""
    if not lines:
        return None
    text = pa.array(lines, pa.string())
    if not pc.all(pc.match_substring_regex(text, ORDINARY)).as_py():
        return None
    words = pc.split_pattern(text, " ").flatten()
    stamps, channels, frames = (_every(words, 3, n) for n in range(3))
    times = pc.cast(pc.utf8_slice_codeunits(stamps, 1, -1), pa.float64())
    halves = pc.split_pattern(frames, "#").flatten()
    encoded = _every(halves, 2, 0).dictionary_encode()
    identifiers = [(int(ident, 16), len(ident) > _STANDARD_DIGITS)
                   for ident in encoded.dictionary.to_pylist()]
    index = encoded.indices.to_numpy().astype(np.int32)
    ids = np.array([ident for ident, _ in identifiers], np.int32)[index]
    extended = np.array([flag for _, flag in identifiers], np.bool_)[index]
    return ArrowColumns(times, channels, pa.array(ids, pa.int32()),
                        pa.array(extended, pa.bool_()), _hex_bytes(_every(halves, 2, 1)),
                        identifiers, index)
