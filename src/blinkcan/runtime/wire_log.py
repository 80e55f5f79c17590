"""The record of a simulated wire: every frame with the virtual time it went on the wire.

Read as a list of :class:`TimedFrame` (index, slice, iterate, ``len``, ``==`` with a list),
kept as two columns, the times in an ``array`` and the frames in a list. Why: a simulation of a
busy bus records hundreds of thousands of frames, and a ``TimedFrame`` made for each is one
more object for the garbage collector's full passes to walk, which grew with the record (about a
quarter of a saturated bus's time); a twin's periodic frame is one object sent again and again,
so the columns hold no new object per frame. A ``TimedFrame`` is made when it is read.
"""

from __future__ import annotations

from array import array
from bisect import bisect_left
from collections.abc import Callable, Iterator, Sequence
from typing import NamedTuple, overload

from blinkcan.protocol.frame import Frame

_timed = tuple.__new__  # TimedFrame without its __new__: a frame and a time made here


class TimedFrame(NamedTuple):
    """A frame as it went on the wire at virtual time ``time``."""

    time: float
    frame: Frame

    def __str__(self) -> str:
        return f"{self.time:10.6f}  {self.frame}"


class WireLog(Sequence[TimedFrame]):
    """Every frame that went on the wire, in order, with its virtual time (times never go
    back); see the module docstring."""

    __slots__ = ("_frames", "_times")

    def __init__(self) -> None:
        self._times = array("d")
        self._frames: list[Frame] = []

    def record(self, time: float, frame: Frame) -> None:
        """``frame`` went on the wire at ``time``."""
        self._times.append(time)
        self._frames.append(frame)

    def writers(self) -> tuple[Callable[[float], None], Callable[[Frame], None]]:
        """:meth:`record` as two appends, the time's and the frame's, for the wire's path of
        every frame (call both, in that order)."""
        return self._times.append, self._frames.append

    def since(self, start: float) -> list[TimedFrame]:
        """The records at or after ``start``."""
        return self[bisect_left(self._times, start):]

    def clear(self) -> None:
        del self._times[:]
        self._frames.clear()

    def copy(self) -> list[TimedFrame]:
        return list(self)

    def __len__(self) -> int:
        return len(self._frames)

    @overload
    def __getitem__(self, index: int) -> TimedFrame: ...

    @overload
    def __getitem__(self, index: slice) -> list[TimedFrame]: ...

    def __getitem__(self, index: int | slice) -> TimedFrame | list[TimedFrame]:
        if isinstance(index, slice):
            return [_timed(TimedFrame, pair)
                    for pair in zip(self._times[index], self._frames[index], strict=True)]
        return _timed(TimedFrame, (self._times[index], self._frames[index]))

    def __iter__(self) -> Iterator[TimedFrame]:
        for pair in zip(self._times, self._frames, strict=False):
            yield _timed(TimedFrame, pair)

    def __eq__(self, other: object) -> bool:
        if isinstance(other, WireLog):
            return self._times == other._times and self._frames == other._frames
        if isinstance(other, Sequence) and not isinstance(other, (str, bytes)):
            return len(other) == len(self) and all(
                mine == theirs for mine, theirs in zip(self, other, strict=True))
        return NotImplemented

    __hash__ = None  # type: ignore[assignment]  # mutable, as a list

    def __add__(self, other: Sequence[TimedFrame]) -> list[TimedFrame]:
        """``rig.frames + more`` is a list, as it was when the record was one."""
        return [*self, *other]

    def __radd__(self, other: Sequence[TimedFrame]) -> list[TimedFrame]:
        return [*other, *self]

    def __repr__(self) -> str:
        return f"WireLog({list(self)!r})"
