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
from collections.abc import Callable

from blinkcan.protocol.frame import Frame

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



#: the most periods a late :class:`Ticker` makes up for at one wake-up (the one due included)
CATCH_UP_PERIODS = 32


class Ticker:
    """A periodic event due at ``origin + k x period`` (k = 1, 2, ...; whole ticks).

    The schedule is a device's clock and is kept however late the caller wakes: a wake-up
    ``k`` periods late owes the ``k`` periods' events, sent late (as python-can's
    ``send_periodic`` does) rather than dropped, and the next one stays on the schedule. Only
    the last :data:`CATCH_UP_PERIODS` are made up for; older ones are skipped, the schedule
    still kept. Why a bound, and why 32: a stall of a loaded host's real-time loop (GC, OS
    time slices on a busy machine) lasts tens to a few hundred milliseconds, which 32 periods
    of the devices' usual 10 ms cover, so no frame is lost (measured: at 4 or 8, frames were
    still dropped on a loaded 2-core machine, benchmarks/emulator_capacity.py); a longer stall
    means the host fell behind for good, and making all of it up would be an unbounded burst
    of stale frames per timer that only makes the next wake-ups later still.
    """

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

    def overdue(self, now: float) -> int:
        """How many of its periods are due by ``now`` (0: not due), at most
        :data:`CATCH_UP_PERIODS`; nothing changes."""
        due, step = self.due, self._ticks
        if due is not None and step > 0 and now >= due:  # the usual case first (see fire)
            origin = self._origin
            after = origin + (self._count + step) / TICKS_PER_S
            if origin < after and now < after:
                return 1
        return min(self._periods_due(now), CATCH_UP_PERIODS)

    def fire(self, now: float) -> int:
        """The number of events owed by ``now`` (:meth:`overdue`; 0, false, when not due);
        the event is then due next strictly after ``now``, on the same schedule."""
        due = self.due
        if due is None or now < due:
            return 0
        step = self._ticks
        if step <= 0:
            self.due = None
            return 1
        # the usual wake-up, before the next one is due: one owed (what the general path below
        # finds, computed once; ``at`` inlined, its rounding rule taken when it applies)
        origin, count = self._origin, self._count + step
        after = origin + count / TICKS_PER_S
        if origin < after and now < after:
            self._count, self.due = count, after
            return 1
        last = self._last_due_count(now)
        owed = min((last - self._count) // self._ticks + 1, CATCH_UP_PERIODS)
        self._count = last + self._ticks
        self.due = at(self._origin, self._count)  # > now: ``last`` is the last one due
        return owed

    def _periods_due(self, now: float) -> int:
        due = self.due
        if due is None or now < due:
            return 0
        if self._ticks <= 0:
            return 1
        return (self._last_due_count(now) - self._count) // self._ticks + 1

    def _last_due_count(self, now: float) -> int:
        """The count of the last tick of the schedule at or before ``now`` (the due one is)."""
        step, origin = self._ticks, self._origin
        after = origin + (self._count + step) / TICKS_PER_S  # at(), inlined: the usual case
        if origin < after and now < after:
            return self._count
        periods = math.floor((now - at(origin, self._count)) * TICKS_PER_S / step)
        last = self._count + step * max(0, periods)
        while at(origin, last + step) <= now:  # the estimate rounded down
            last += step
        while last > self._count and at(origin, last) > now:  # ... or up
            last -= step
        return last


def milliseconds(count: int) -> int:
    """Ticks in ``count`` whole milliseconds (the unit of the CANopen period objects)."""
    return count * TICKS_PER_S // 1000


class Periodic(Ticker):
    """A periodic producer registered with a twin (``twin.add_timer``): ``produce(now)`` runs
    every ``period`` seconds from :meth:`start` until :meth:`stop`, at exact times
    (:mod:`blinkcan.twin.schedule`). ``produce`` may change :attr:`period`; the next run is
    counted from the one that was due. Woken late, it runs once for each period owed
    (:meth:`~blinkcan.twin.schedule.Ticker.fire`)."""

    __slots__ = ("produce",)

    def __init__(self, produce: Callable[[float], list[Frame]]) -> None:
        super().__init__()
        self.produce = produce

    def start(self, period: float, now: float, running: bool = True) -> None:
        """Run every ``period`` s from ``now`` (a period of 0, or ``running=False``, stops)."""
        self.run(now, ticks(period), running)

    @property
    def period(self) -> float:
        return self.period_ticks / TICKS_PER_S

    @period.setter
    def period(self, seconds: float) -> None:
        self.retime(ticks(seconds))

    def advance(self, now: float) -> list[Frame]:
        due = self.due
        if due is None or now < due:
            return []
        step, origin, count = self._ticks, self._origin, self._count
        after = origin + (count + step) / TICKS_PER_S
        if step > 0 and origin < after and now < after:
            # the usual wake-up, one period owed (overdue() and fire() computed once, inlined:
            # every periodic frame comes this way): the producer's own list, no copy
            frames = self.produce(now)
            if self.due == due and self._ticks == step and self._origin == origin:
                self._count, self.due = count + step, after  # what fire(now) does here
            elif self.due == due:  # retimed by produce (not stopped or started again)
                self.fire(now)
            return frames
        owed = self.overdue(now)
        if owed == 1:
            frames = self.produce(now)
            if self.due == due:  # not stopped, started again or retimed by produce
                self.fire(now)
            return frames
        frames = []
        for _ in range(owed):  # late: the owed periods, late (twin/schedule.py)
            frames += self.produce(now)
            if self.due != due:  # stopped, started again or retimed by produce
                return frames
        self.fire(now)
        return frames
