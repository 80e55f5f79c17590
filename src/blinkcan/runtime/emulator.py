"""Run twins on a bus: the only place where twins meet threads and clocks.

The emulator runs on a scheduler (``runtime.scheduler``). On a python-can bus that is a
real-time scheduler: a ``Notifier`` reads the bus and hands each frame to the twins at once, on
its own thread; the scheduler's thread runs the timers and the actions of other threads. A lock
makes them take turns, so twins are only ever called one at a time. (Handing frames over to the
scheduler's thread instead would add a thread switch to every request; see the benchmarks.)
On a ``SimulatedBus`` the emulator runs in the simulation's virtual time instead: frames and
timers are events of the simulated scheduler, with no thread at all (``blinkcan.testing``).
Rules:
- Frames a twin sends go on the bus and, because a bus does not echo its own frames, are also
  delivered to the other twins of this emulator that listen to that COB-ID.
- Timers come from ``twin.next_deadline()``, kept in a heap; lateness is recorded.
- With ``response_delay`` > 0 a twin's reply leaves that long after the request, and an SDO
  request that reaches a twin still busy answering the previous one is dropped, as real keypads
  do (errata.md, field reports).
- An exception in a twin is logged with its traceback and never stops the loop (in simulated
  time it is raised again from the call that ran the simulation, as a handler's is).
- Every deadline a twin names is consumed when time reaches it: after ``advance(now)`` the
  twin's next deadline is later than ``now``. A twin that breaks this would make the loop spin
  at that instant; in simulated time that is a ``StuckDeadlineError`` naming the twin and the
  time, in real time it is logged and the twin is asked again a little later.
- The bus is read as every blinkcan reader reads it (``runtime.canbus.BusReader``): a frame
  it cannot decode is counted and dropped, a failing bus is read with a back-off, a shut-down
  bus stops the reader; each is logged once.
- Frames the emulator sent never come back to it as received ones, also on python-can's
  ``udp_multicast``, which echoes them (``runtime.canbus.OwnFrames``).
"""

from __future__ import annotations

import heapq
import itertools
import logging
import threading
import time
from collections import deque
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import Any, TypeVar

import can

from blinkcan.protocol.cob import check_time
from blinkcan.protocol.frame import Frame
from blinkcan.runtime.canbus import BusReader, OwnFrames, ReadStats, to_frame, to_message
from blinkcan.runtime.scheduler import (
    RealTimeScheduler,
    Scheduler,
    StuckDeadlineError,
    Timer,
)
from blinkcan.runtime.simbus import SimulatedBus
from blinkcan.twin.base import CanopenTwin

log = logging.getLogger(__name__)
T = TypeVar("T")
#: real time: how long a twin whose deadline did not move waits before it is asked again
_STUCK_RETRY_S = 0.001


@dataclass
class EmulatorStats:
    """Counters and the lateness of timed frames (seconds after their deadline)."""

    frames_sent: int = 0
    frames_received: int = 0
    send_errors: int = 0
    twin_errors: int = 0
    #: what reading the bus met: frames it could not decode, failures, a shut-down
    reading: ReadStats = field(default_factory=ReadStats)
    lateness: deque[float] = field(default_factory=lambda: deque(maxlen=200_000))


class _Listener(can.Listener):
    def __init__(self, emulator: Emulator) -> None:
        self._emulator = emulator

    def on_message_received(self, msg: can.Message) -> None:
        self._emulator._from_reader(msg)


class Emulator:
    """Drives ``twins`` on ``bus``. Powers the twins on at :meth:`start`."""

    def __init__(
        self,
        bus: can.BusABC,
        twins: Iterable[CanopenTwin],
        response_delay: float = 0.0,
        notifier: can.Notifier | None = None,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        check_time("response_delay", response_delay, 0)
        self.bus = bus
        self.twins: list[CanopenTwin] = list(twins)
        self.response_delay = response_delay
        self.stats = EmulatorStats()
        self.scheduler: Scheduler = (bus.scheduler if isinstance(bus, SimulatedBus)
                                     else RealTimeScheduler("blinkcan-emulator", clock))
        self._clock = self.scheduler.clock
        self._given_notifier = notifier
        self._reader: BusReader | None = None
        self._detach: Callable[[], None] | None = None
        self._listener = _Listener(self)
        self._own = OwnFrames(bus)
        self._lock = threading.RLock()
        self._planned: tuple[float, Timer] | None = None
        self._running = False
        self._timers: list[tuple[float, int, int]] = []  # (deadline, seq, twin index)
        self._deadline: list[float | None] = [None] * len(self.twins)
        self._delayed: list[tuple[float, int, int, list[Frame]]] = []
        self._busy_until: list[float] = [0.0] * len(self.twins)
        self._seq = itertools.count()
        self._index: dict[int, tuple[int, ...]] = {}
        self._routes_seen: list[object] = [None] * len(self.twins)
        self._index_dirty = True
        self._stuck_reported: set[int] = set()
        #: frames that could not be sent since the last one that could (logged once, counted)
        self._failing_sends = 0
        #: optional tap: ``on_frame(frame, sent, now)`` for every frame sent or received
        self.on_frame: Callable[[Frame, bool, float], object] | None = None

    # -- lifecycle --------------------------------------------------------------------------

    def start(self) -> Emulator:
        if self._running:
            raise RuntimeError("emulator already started")
        self._running = True
        self.scheduler.start()
        bus = self.bus
        if isinstance(bus, SimulatedBus):
            self._detach = bus.add_frame_listener(self._from_simulation)
        else:
            self._reader = BusReader(bus, self._listener, self._given_notifier,
                                     stats=self.stats.reading)
        self.run(self._power_on_all)
        return self

    def stop(self) -> None:
        if not self._running:
            return
        self._running = False
        if self._planned is not None:
            self._planned[1].cancel()
            self._planned = None
        if self._detach is not None:
            self._detach()
            self._detach = None
        if self._reader is not None:
            self._reader.stop()
            self._reader = None
        if not self.scheduler.simulated:
            self.scheduler.stop()
        with self._lock:
            failing, self._failing_sends = self._failing_sends, 0
        if failing:
            log.warning("%d frames could not be sent", failing)

    def __enter__(self) -> Emulator:
        return self.start()

    def __exit__(self, *exc_info: object) -> None:
        self.stop()

    # -- acting on twins from other threads --------------------------------------------------

    def run(self, action: Callable[[float], T], timeout: float = 5.0) -> T:
        """Run ``action(now)`` on the emulator's loop and return its result. A list of frames
        it returns is sent, as if the device had sent it."""
        if not self._running:
            raise RuntimeError("emulator not started")

        def perform() -> T:
            with self._lock:
                result = self._perform(action)
                self._arm()
                return result

        return self.scheduler.run(perform, timeout)

    def add(self, twin: CanopenTwin) -> CanopenTwin:
        """One more twin on this bus; powered on at once when the emulator runs."""
        with self._lock:
            self.twins.append(twin)
            self._deadline.append(None)
            self._busy_until.append(0.0)
            self._routes_seen.append(None)
            self._index_dirty = True
            index = len(self.twins) - 1
        if self._running:

            def power_on(now: float) -> list[Frame]:
                frames = self._call(index, twin.power_on, now)
                self._reschedule(index)
                self._emit(index, frames, now)
                return []

            self.run(power_on)
        return twin

    @property
    def pending_replies(self) -> int:
        """Replies held back by ``response_delay`` and not yet sent."""
        return len(self._delayed)

    def press(self, twin: Any, key: int) -> list[Frame]:
        return self.run(lambda now: twin.press(key, now))

    def release(self, twin: Any, key: int) -> list[Frame]:
        return self.run(lambda now: twin.release(key, now))

    def power_off(self, twin: CanopenTwin) -> None:
        self.run(lambda now: twin.power_off())

    def power_on(self, twin: CanopenTwin) -> list[Frame]:
        return self.run(twin.power_on)

    def power_cycle(self, twin: CanopenTwin, off_time: float = 0.0) -> list[Frame]:
        check_time("off_time", off_time, 0)
        self.power_off(twin)
        if off_time:
            self.scheduler.sleep(off_time)
        return self.power_on(twin)

    def snapshot(self, twin: CanopenTwin) -> dict[str, Any]:
        return self.run(lambda now: twin.snapshot())

    # -- the loop ----------------------------------------------------------------------------

    def _power_on_all(self, now: float) -> list[Frame]:
        for i, twin in enumerate(self.twins):
            frames = self._call(i, twin.power_on, now)
            self._reschedule(i)
            self._emit(i, frames, now)
        return []

    def _from_reader(self, message: can.Message) -> None:
        """A frame from the bus, on the notifier's thread: straight to the twins."""
        frame = to_frame(message)
        if frame is None:
            return
        with self._lock:
            now = self._clock()
            if self._own.active and self._own.is_echo(frame, now):
                return
            self._received(frame, now)

    def _from_simulation(self, frame: Frame, now: float) -> None:
        with self._lock:
            self._received(frame, now)

    def _received(self, frame: Frame, now: float) -> None:
        self.stats.frames_received += 1
        if self.on_frame is not None:
            self.on_frame(frame, False, now)
        self._deliver(frame, None, now)
        self._arm()

    def _arm(self) -> None:
        """Keep one scheduler timer at the earliest twin deadline or delayed reply."""
        if not self._running:
            return
        wake = self._next_wakeup()
        planned = self._planned
        if planned is not None:
            if wake is not None and planned[0] <= wake:
                return  # the planned tick comes first; it re-arms
            planned[1].cancel()
            self._planned = None
        if wake is not None:
            self._planned = (wake, self.scheduler.call_at(wake, self._tick))

    def _tick(self) -> None:
        with self._lock:
            self._planned = None
            if self._running:
                try:
                    self._run_timers(self._clock())
                finally:
                    self._arm()

    def _perform(self, action: Callable[[float], T]) -> T:
        now = self._clock()
        result = action(now)
        for i in range(len(self.twins)):
            self._reschedule(i)
        if isinstance(result, list) and all(isinstance(f, Frame) for f in result):
            self._emit(-1, result, now)  # a device's frames: every other twin may listen
        return result

    def _call(self, i: int, method: Callable[..., list[Frame]], *args: Any) -> list[Frame]:
        try:
            return method(*args)
        except Exception as error:
            self.stats.twin_errors += 1
            self.scheduler.failed(error, f"twin {self._name(i)}")
            return []

    def _deliver(self, frame: Frame, source: int | None, now: float) -> None:
        """Give ``frame`` to every twin listening to its COB-ID except its sender."""
        targets = self._targets(frame)
        for i in targets:
            if i == source:
                continue
            twin = self.twins[i]
            if self.response_delay:
                if twin.is_sdo_request(frame):
                    if now < self._busy_until[i]:
                        continue  # still answering the previous request: dropped
                    self._busy_until[i] = now + self.response_delay
                replies = self._call(i, twin.receive, frame, now)
                self._reschedule(i)
                if replies:
                    due = now + self.response_delay
                    heapq.heappush(self._delayed, (due, next(self._seq), i, replies))
            else:
                replies = self._call(i, twin.receive, frame, now)
                self._reschedule(i)
                self._emit(i, replies, now)

    def _targets(self, frame: Frame) -> Iterable[int]:
        if frame.extended:
            return range(len(self.twins))
        self._refresh_index()
        return self._index.get(frame.can_id, ())

    def _refresh_index(self) -> None:
        """Rebuild COB-ID -> twins after any twin's routes changed (a boot, a new node id)."""
        if not self._index_dirty:
            return
        self._index_dirty = False
        index: dict[int, list[int]] = {}
        for i, twin in enumerate(self.twins):
            self._routes_seen[i] = twin.listening
            for can_id in twin.listening:
                index.setdefault(can_id, []).append(i)
        self._index = {can_id: tuple(ids) for can_id, ids in index.items()}

    def _emit(self, source: int, frames: list[Frame], now: float) -> None:
        for frame in frames:
            try:
                if isinstance(self.bus, SimulatedBus):
                    self.bus.send_frame(frame)
                else:
                    self._own.sent(frame, now)
                    self.bus.send(to_message(frame, now))
                self.stats.frames_sent += 1
                if self._failing_sends:
                    log.warning("bus sends again after %d frames could not be sent",
                                self._failing_sends)
                    self._failing_sends = 0
                if self.on_frame is not None:
                    self.on_frame(frame, True, now)
            except can.CanError as error:
                self.stats.send_errors += 1
                self._failing_sends += 1
                if self._failing_sends == 1:  # a shut-down bus fails every frame: log once
                    log.warning("send failed for %r: %s (further failures are counted, "
                                "reported when it sends again or stops)", frame, error)
            self._deliver(frame, source, now)

    def _reschedule(self, i: int) -> None:
        """After any call into twin ``i``: its next deadline, and whether its routes changed
        (only a call into a twin can change them, so no other twin needs a look)."""
        twin = self.twins[i]
        if twin.listening is not self._routes_seen[i]:
            self._index_dirty = True
        deadline = twin.next_deadline()
        if deadline != self._deadline[i]:
            self._deadline[i] = deadline
            if deadline is not None:
                heapq.heappush(self._timers, (deadline, next(self._seq), i))

    def _next_wakeup(self) -> float | None:
        timers, delayed = self._timers, self._delayed
        while timers and timers[0][0] != self._deadline[timers[0][2]]:
            heapq.heappop(timers)  # stale entry
        candidates = [heap[0][0] for heap in (timers, delayed) if heap]
        return min(candidates) if candidates else None

    def _run_timers(self, now: float) -> None:
        delayed = self._delayed
        while delayed and delayed[0][0] <= now:
            _due, _, i, frames = heapq.heappop(delayed)
            self._emit(i, frames, now)
        timers = self._timers
        lateness = self.stats.lateness
        stuck: list[int] = []
        while timers and timers[0][0] <= now:
            deadline, _, i = heapq.heappop(timers)
            if deadline != self._deadline[i]:
                continue
            self._deadline[i] = None
            frames = self._call(i, self.twins[i].advance, now)
            self._reschedule(i)
            following = self._deadline[i]
            if following is not None and following <= now:
                stuck.append(i)  # advance(now) left it due: asking again would spin
                self._deadline[i] = None
            if frames:
                lateness.append(now - deadline)
                self._emit(i, frames, now)
        for i in stuck:
            self._stuck(i, now)

    def _stuck(self, i: int, now: float) -> None:
        """Twin ``i`` named a deadline that ``advance(now)`` did not consume."""
        deadline = self.twins[i].next_deadline()
        message = (f"twin {self._name(i)} names deadline t={deadline!r} s that advance() at "
                   f"t={now!r} s did not consume: time could not move past it")
        if self.scheduler.simulated:
            raise StuckDeadlineError(message)  # the simulation would spin here for ever
        if i not in self._stuck_reported:  # once per twin: it is asked again every retry
            self._stuck_reported.add(i)
            log.error("%s; asking it again every %g s", message, _STUCK_RETRY_S)
        retry = now + _STUCK_RETRY_S
        self._deadline[i] = retry
        heapq.heappush(self._timers, (retry, next(self._seq), i))

    def _name(self, i: int) -> str:
        twin = self.twins[i]
        return f"{type(twin).__name__} at node {twin.node_id:02X}h"
