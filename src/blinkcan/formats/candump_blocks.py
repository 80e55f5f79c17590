"""A block of candump ``-L`` lines that are all plain data frames, read whole in pure Python.

Reading a log line by line (formats/candump.py) costs a split, a partition and a few checks a
line in Python. Nearly every block of a capture is plain data frames
(``(1700000000.000500) can0 715#0501``), so a block is read whole by ``str`` and ``bytes``
methods and ``map`` (``float``, ``bytes.fromhex``), with no Python code per line:

- its skeleton: the block with every hex digit deleted (one ``bytes.translate``) is its first
  line's, once per line, and that is a plain data frame's (a pattern checks it; where the
  channels differ, each distinct line skeleton is checked): so every line is
  ``(TIME) CHANNEL ID#DATA``, and only hex digits differ;
- its fields: the separators turned into spaces and the block split once, every fourth
  field the time, channel, identifier and data of the next line;
- each distinct identifier text checked once (3 digits up to 7FFh, 8 up to 1FFFFFFFh: no
  error flag) and its value remembered; the data at most 8 bytes of whole bytes
  (``bytes.fromhex`` refuses an odd digit), the times finite.

A block with any other line (a comment, a blank line, CRLF, a remote, CAN FD or error frame,
a direction, a line that is no frame) is read line by line as before: what is accepted here
is what the line reader reads as plain data frames, with the same columns
(tests/formats/test_candump_blocks.py compares the two on generated logs). No python-can, no
pyarrow: ``decode --json`` starts without them.
"""

from __future__ import annotations

import math
import re

from blinkcan.formats.columns import FrameColumns

_HEX_DIGITS = b"0123456789abcdefABCDEF"
#: a plain data-frame line's skeleton (its hex digits deleted): the time's parentheses and
#: point, a channel with a character that is not a hex digit (so never empty) and none of
#: the separators, the identifier's '#'
_PLAIN_SKELETON = re.compile(rb"\(\.\) [!-\"$-'*-~]+ #")
#: the identifier texts remembered (then they start over): a log has a few hundred
_IDENTS_KEPT = 4096
_EXTENDED_DIGITS = 8
_STANDARD_MAX, _EXTENDED_MAX = 0x7FF, 0x1FFFFFFF
_DATA_DIGITS_MAX = 16


class PlainBlocks:
    """Reads the blocks of one log: ``plain(lines)`` (ASCII lines without their newlines) is
    the block's columns where every line is a plain data frame, else None (then the caller
    reads them line by line). Remembers the identifier texts it has checked."""

    def __init__(self) -> None:
        self._ids: dict[str, int] = {}

    def __call__(self, lines: list[str]) -> FrameColumns | None:
        if not lines:
            return None
        text = "\n".join(lines)
        skeleton = text.encode("ascii").translate(None, _HEX_DIGITS)
        first = lines[0].encode("ascii").translate(None, _HEX_DIGITS)
        if skeleton != b"\n".join((first,) * len(lines)):  # not one channel (candump any)
            if not all(map(_PLAIN_SKELETON.fullmatch, set(skeleton.split(b"\n")))):
                return None
        elif _PLAIN_SKELETON.fullmatch(first) is None:
            return None
        # every line '(TIME) CHANNEL ID#DATA': 4 fields a line, in this order
        fields = text.replace("#", " ").replace(") ", " ").replace("\n(", " ")[1:].split(" ")
        channels: list[str | None] = fields[1::4]  # type: ignore[assignment]  # str only
        idents, data = fields[2::4], fields[3::4]
        ids = self._ids
        if not (ids.keys() >= set(idents) or self._known(idents)) or \
                max(map(len, data)) > _DATA_DIGITS_MAX:
            return None
        try:
            times = list(map(float, fields[0::4]))
            payloads = list(map(bytes.fromhex, data))
        except ValueError:  # not a number (hex letters in the time), an odd digit
            return None
        if not max(times) < math.inf:  # 400 digits: candump's lines say no such time
            return None
        return FrameColumns(
            times=times, channels=channels, ids=list(map(ids.__getitem__, idents)),
            extended=list(map(_EXTENDED_DIGITS.__eq__, map(len, idents))), data=payloads)

    def _known(self, idents: list[str]) -> bool:
        """Remember the identifiers new in ``idents``; False where one is not a plain data
        frame's (python-can's rules decide: over 7FFh in 3 digits, an error flag in 8)."""
        ids = self._ids
        for ident in set(idents).difference(ids):
            if len(ident) not in (3, _EXTENDED_DIGITS):
                return False
            can_id = int(ident, 16)
            if can_id > (_EXTENDED_MAX if len(ident) == _EXTENDED_DIGITS else _STANDARD_MAX):
                return False
            if len(ids) >= _IDENTS_KEPT:
                ids.clear()
            ids[ident] = can_id
        return True
