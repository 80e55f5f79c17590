"""A line of a log that is not a frame: skipped, never hidden (issue 23: "a file that cannot
be read is named, counted and skipped, never stops the run"; nothing a user recorded is lost).

A reader that meets a line it cannot read (a corrupt byte, a line two writers interleaved,
the half line a killed logger left) yields an :class:`UnreadableLine` in its place and goes
on: every frame after it is read. Outputs that can carry it keep it where it was (``decode
--json``: an ``unreadable`` object; the fleet's dataset: an ``unreadable`` row with the raw
text); every command names the first few on stderr and counts them all
(:class:`UnreadableCount`). A file none of whose lines is a frame is not a log of that
format: the reader raises once it has read it all.
"""

from __future__ import annotations

from typing import NamedTuple

#: characters of a line an error message shows
SHOWN = 40


def printable(line: str) -> str:
    """``line`` as text any output takes: a byte that is not UTF-8 (read as a surrogate
    escape) as ``\\xNN``, the line end's ``\\r`` dropped."""
    line = line.rstrip("\r")
    if line.isascii():
        return line
    return line.encode("utf-8", "surrogateescape").decode("utf-8", "backslashreplace")


def shown(line: str) -> str:
    """A line as an error message names it: quoted, at most :data:`SHOWN` characters."""
    text = printable(line).strip()
    return "'" + (text if len(text) <= SHOWN else text[:SHOWN] + "...") + "'"


class UnreadableLine(NamedTuple):
    """Line ``number`` (from 1) of a log, which is not a frame: ``text`` as the file holds it
    (:func:`printable`), ``reason`` why it cannot be read (it quotes the line, clipped),
    ``time`` the time it starts with where that reads as one, ``cut_off`` when it is the
    file's last line and no newline follows it (a logger killed mid-write). A named tuple:
    it costs the start-up nothing (a dataclass compiles its methods on import)."""

    number: int
    text: str
    reason: str
    time: float | None = None
    cut_off: bool = False
    unit: str = "line"  # a pcap capture's: "packet"

    def __str__(self) -> str:
        """"line 7: 'garbage' is not a candump line ((TIME) CHANNEL ID#DATA)"."""
        ending = ": the capture ends there, cut off" if self.cut_off and \
            "cut short" not in self.reason else ""
        return f"{self.unit} {self.number}: {self.reason}{ending}"

    def to_json(self) -> dict[str, object]:
        """The line as ``decode --json`` writes it, among the frames' objects."""
        return {"time": self.time, "kind": "unreadable", "line": self.number,
                "text": self.text, "error": str(self)}


class UnreadableCount:
    """The unreadable lines of one log: how many, the first :attr:`NAMED` of them, and the
    one a capture was cut off at."""

    NAMED = 5

    def __init__(self) -> None:
        self.count = 0
        self.named: list[UnreadableLine] = []
        self.cut_off: UnreadableLine | None = None

    def add(self, line: UnreadableLine) -> None:
        self.count += 1
        if len(self.named) < self.NAMED:
            self.named.append(line)
        if line.cut_off:
            self.cut_off = line

    def summary(self, source: object, kept: str, frames: int | None = None) -> str:
        """"trace.log: 3 lines could not be read (lines 2, 7, 9): ``kept``; the 2,998
        frames around them were read" (``frames`` None: that part left out)."""
        numbers = ", ".join(str(line.number) for line in self.named)
        more = ", ..." if self.count > len(self.named) else ""
        plural = "s" if self.count != 1 else ""
        unit = self.named[0].unit if self.named else "line"
        read = "" if frames is None else \
            f"; the {frames:,} frames around {'them' if plural else 'it'} were read"
        return (f"{source}: {self.count:,} {unit}{plural} could not be read ({unit}{plural} "
                f"{numbers}{more}): {kept}{read}")
