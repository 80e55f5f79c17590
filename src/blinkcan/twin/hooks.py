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


def next_due(due: float, period: float, now: float) -> float:
    """The next time of a periodic event that was due at ``due``: no drift, and no burst of
    catch-up frames after a stall."""
    due += period
    return due if due > now else now + period


class Periodic:
    """A periodic producer registered with a twin (``twin.add_timer``): ``produce(now)`` runs
    every ``period`` seconds from :meth:`start` until :meth:`stop`. ``produce`` may change
    :attr:`period`; the next run is counted from the one that was due."""

    __slots__ = ("due", "period", "produce")

    def __init__(self, produce: Action) -> None:
        self.produce = produce
        self.period = 0.0
        #: when it next runs, or None while stopped
        self.due: float | None = None

    def start(self, period: float, now: float, running: bool = True) -> None:
        """Run every ``period`` s from ``now`` (a period of 0, or ``running=False``, stops)."""
        self.period = period
        self.due = now + period if running and period else None

    def stop(self) -> None:
        self.due = None

    @property
    def running(self) -> bool:
        return self.due is not None

    def advance(self, now: float) -> list[Frame]:
        due = self.due
        if due is None or now < due:
            return []
        frames = self.produce(now)
        self.due = next_due(due, self.period, now)
        return frames
