"""The ways a model's behaviour plugs into a twin: hooks of the shape ``(value, now) -> frames |
abort``, registered with :class:`~blinkcan.twin.base.CanopenTwin`, and periodic producers.

A hook gets what it acts on and the time as arguments and returns what the device sends; it never
reads a clock, and it reaches the twin only through the twin's public methods. Frames a write hook
returns are sent after the SDO reply (or the RPDO) that caused them.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from typing import Any

from blinkcan.devices.objects import Value
from blinkcan.protocol.abort import AbortCode
from blinkcan.protocol.frame import Frame
from blinkcan.protocol.nmt import NmtState
from blinkcan.twin.schedule import TICKS_PER_S, Ticker, ticks

#: an object written (SDO or RPDO): frames to send after the reply, an abort code to refuse the
#: value, or None
WriteHook = Callable[[Any, float], "list[Frame] | AbortCode | None"]
#: an RPDO's data (its length is the frame's DLC): the frames the device sends in reaction
RpdoHook = Callable[[bytes, float], list[Frame]]
#: a frame on a COB-ID the model listens to besides the standard ones (SYNC)
FrameHook = Callable[[Frame, float], list[Frame]]
#: sees a frame before it is acted on
Watcher = Callable[[Frame, float], None]
#: power-on, reset node or reset communication (``application``: power-on or reset node)
BootHook = Callable[[float, bool], list[Frame]]
#: an NMT state change: (previous, new state, now)
StateHook = Callable[[NmtState, NmtState, float], list[Frame]]
#: something to do at ``now``: the frames it sends
Action = Callable[[float], list[Frame]]
#: times at which the twin has work (None: none), asked with the time of the last input
DeadlineSource = Callable[[float], Iterable[float | None]]
#: extra snapshot() entries, asked with the time of the last input
SnapshotHook = Callable[[float], Mapping[str, object]]
#: settings kept in the NVM beside the objects' (the keypad's J1939 settings)
ExtraSettings = Callable[[], Mapping[str, Value]]


class Periodic(Ticker):
    """A periodic producer registered with a twin (``twin.add_timer``): ``produce(now)`` runs
    every ``period`` seconds from :meth:`start` until :meth:`stop`, at exact times
    (:mod:`blinkcan.twin.schedule`). ``produce`` may change :attr:`period`; the next run is
    counted from the one that was due. Woken late, it runs once for each period owed
    (:meth:`~blinkcan.twin.schedule.Ticker.fire`)."""

    __slots__ = ("produce",)

    def __init__(self, produce: Action) -> None:
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
        owed = self.overdue(now)
        if owed == 1:  # the usual wake-up: the producer's own list, no copy
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
