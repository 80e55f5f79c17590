"""Exact schedules: every deadline a twin names is an origin plus whole ticks, computed one way.

Why: deadlines built by adding float periods drift (0.1 added ten times is not 1.0), and a
deadline computed again another way at its own time can come out a hair after the time it
named, so ``advance()`` at that time would not consume it and a simulation would spin on it.
Here a deadline is :func:`at` ``(origin, ticks)``: the origin plus a whole number of ticks of
:data:`TICK_S`, rounded once. It is the one float ``next_deadline()`` names and ``advance()``
compares with, and a consumed deadline is always followed by one strictly later.
"""

from __future__ import annotations

import math

TICKS_PER_S = 1000
#: the base period: every period and step of the devices is a whole number of milliseconds
TICK_S = 1 / TICKS_PER_S


def ticks(seconds: float) -> int:
    """A duration of the devices (a period, a show step) in whole ticks."""
    return round(seconds * TICKS_PER_S)


def at(origin: float, count: int) -> float:
    """``origin`` + ``count`` ticks, rounded once; always after ``origin`` when ``count`` > 0."""
    time = origin + count / TICKS_PER_S
    if time <= origin and count > 0:  # a tick below the clock's resolution at ``origin``
        return math.nextafter(origin, math.inf)
    return time



class Ticker:
    """A periodic event due at ``origin + k x period`` (k = 1, 2, ...; whole ticks). After a
    stall it starts again from the time it was late at: no drift, and no burst of catch-up."""

    __slots__ = ("_count", "_origin", "_ticks", "due")

    def __init__(self) -> None:
        #: when the event is next due, or None while it does not run
        self.due: float | None = None
        self._origin = 0.0
        self._ticks = 0
        self._count = 0

    def run(self, now: float, period: int, running: bool = True) -> None:
        """Run every ``period`` ticks from ``now`` (first at ``now`` + period); a period of 0,
        or ``running=False``, stops it (the period is kept)."""
        self._ticks = period
        if period <= 0 or not running:
            self.due = None
            return
        self._origin, self._count = now, period
        self.due = at(now, period)

    def stop(self) -> None:
        self.due = None

    @property
    def period_ticks(self) -> int:
        return self._ticks

    @property
    def running(self) -> bool:
        return self.due is not None

    def retime(self, period: int) -> None:
        """A new period, counted from the time the event is (or was last) due."""
        if self.due is not None:
            self._origin, self._count = self.due, 0
        self._ticks = period

    def fire(self, now: float) -> bool:
        """True when the event is due by ``now``; it is then due next strictly after ``now``."""
        due = self.due
        if due is None or now < due:
            return False
        if self._ticks <= 0:
            self.due = None
            return True
        self._count += self._ticks
        following = at(self._origin, self._count)
        if following <= now:  # late: start again from now
            self._origin, self._count = now, self._ticks
            following = at(now, self._ticks)
        self.due = following
        return True


def milliseconds(count: int) -> int:
    """Ticks in ``count`` whole milliseconds (the unit of the CANopen period objects)."""
    return count * TICKS_PER_S // 1000
