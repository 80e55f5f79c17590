"""Run twins on a bus: the only place where twins meet threads and clocks.

The emulator runs on a transport port (``runtime.port``: python-can's or the simulated one,
never asked which) and its scheduler (``runtime.scheduler``). Twins are only ever called on
the scheduler's loop, one call at a time, so nothing needs a lock: on a python-can bus the
reader thread hands each frame to the loop (``scheduler.deliver``: run at once on the reader's
thread, holding the loop, when the loop is idle, else queued after what was posted before;
timers run on the loop's own thread); on a simulated bus the simulation itself is the loop,
in virtual time, with no thread at all (``blinkcan.testing``).
Rules:
- Frames a twin sends go on the bus and, because a bus does not echo its own frames, are also
  delivered to the other twins of this emulator that listen to that COB-ID.
- Timers come from ``twin.next_deadline()``: one scheduler timer per twin; lateness is
  recorded.
- Real devices are not in phase: each powers up at its own moment, so their periodic frames
  do not all fall due at once. The emulator powers each twin up (at :meth:`Emulator.start`
  and :meth:`Emulator.add`) as if it had booted a per-node fraction of ``power_up_spread``
  earlier (:func:`power_up_phase`): its schedules start out of phase with the others', while
  its boot-up frame still goes out at once and it answers at once. The fraction is fixed per
  node id (a golden-ratio sequence: any set of nodes spreads evenly), so runs repeat; a
  power-up asked for by the caller (:meth:`Emulator.power_on`) happens exactly when asked.
  ``power_up_spread=0`` keeps every twin in phase (``blinkcan.testing.Rig`` does: a test's
  timeline is what it says).
- With ``response_delay`` > 0 a twin's reply leaves that long after the request, and an SDO
  request that reaches a twin still busy answering the previous one is dropped, as real keypads
  do (errata.md, field reports).
- An exception in a twin is logged with its traceback and never stops the loop (in simulated
  time it is raised again from the call that ran the simulation, as a handler's is).
- Every deadline a twin names is consumed when time reaches it: after ``advance(now)`` the
  twin's next deadline is later than ``now``. A twin that breaks this would make the loop spin
  at that instant; in simulated time that is a ``StuckDeadlineError`` naming the twin and the
  time, in real time it is logged and the twin is asked again a little later.
- Timers wake the loop on time. Linux lets a sleeping thread's timer fire up to its "timer
  slack" late (50 us by default) to bunch wake-ups; at 46 twins (~9,200 frames/s) that slack
  was most of the emulator's lateness at send (p50 0.07 ms against python-can's
  ``send_periodic`` 0.02-0.03 ms). So the loop thread of a scheduler the emulator made itself
  (given a python-can bus, not a port) asks for a slack of ``LOOP_TIMER_SLACK_NS`` (prctl
  ``PR_SET_TIMERSLACK``: that thread only, Linux only, nothing else changes; elsewhere, or where
  the call is refused, the default stays). It still sleeps until each deadline: no core spins.
  On a machine short of CPU the one loop thread is now and then woken milliseconds late by the
  kernel, as any thread is; every twin due meanwhile is then late with it (``send_periodic``'s
  thread per frame spreads such a stall over one frame), so the p99 at send follows the load.
- The bus is read as every blinkcan reader reads it (the port's: ``runtime.canport``): a frame
  it cannot decode is counted and dropped, a failing bus is read with a back-off, a shut-down
  bus stops the reader; each is logged once. Frames the emulator sent never come back to it as
  received ones, also on python-can's ``udp_multicast``, which echoes them.
"""

from __future__ import annotations

import ctypes
import itertools
import logging
import sys
import time
from collections import deque
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from functools import partial
from typing import Any, TypeVar

import can

from blinkcan.protocol.cob import check_time
from blinkcan.protocol.frame import Frame
from blinkcan.runtime.canbus import ReadStats
from blinkcan.runtime.port import Port, take_port
from blinkcan.runtime.scheduler import Scheduler, StuckDeadlineError, Timer
from blinkcan.twin.base import CanopenTwin

log = logging.getLogger(__name__)
T = TypeVar("T")
#: real time: how long a twin whose deadline did not move waits before it is asked again
_STUCK_RETRY_S = 0.001
#: the window power-up phases spread over: the shortest period the devices' object ranges
#: allow (heartbeat and PDO periods from 10 ms), so no twin starts with a period already owed
DEFAULT_POWER_UP_SPREAD = 0.01
_GOLDEN_FRACTION = (5 ** 0.5 - 1) / 2
#: the timer slack the emulator's own loop thread asks for (module docstring), nanoseconds
LOOP_TIMER_SLACK_NS = 1_000
#: prctl(2) option: this thread's timer slack, nanoseconds (<linux/prctl.h>)
_PR_SET_TIMERSLACK = 29


def power_up_phase(node_id: int, spread: float) -> float:
    """How much earlier than its power-up the twin at ``node_id`` is taken to have booted: a
    fraction of ``spread`` fixed per node, n x golden ratio (mod 1), so that nodes of any
    number and numbering spread evenly over it."""
    return spread * ((node_id * _GOLDEN_FRACTION) % 1.0)


class Twins(list[CanopenTwin]):
    """:attr:`Emulator.twins`: reads as a list, refuses every change by hand. A twin put in
    by hand would miss what the emulator does for each (its power-up, its timer, the COB-ID
    binding: a swapped twin's requests went on to the twin it replaced); :meth:`Emulator.add`
    is the way in, :meth:`Emulator.power_off` the way to silence one."""

    __slots__ = ()

    def _refuse(self, *args: object, **kwargs: object) -> Any:
        raise TypeError("the emulator's twins are not changed by hand: add one with "
                        "Emulator.add(twin) (powered on at once when running), silence one "
                        "with Emulator.power_off(twin)")

    __setitem__ = __delitem__ = __iadd__ = __imul__ = _refuse
    append = extend = insert = remove = pop = clear = sort = reverse = _refuse

    def __reduce_ex__(self, protocol: Any) -> tuple[type[list[CanopenTwin]], tuple[Any, ...]]:
        """A copy (``copy``, ``pickle``) is a plain list: the caller's to change."""
        return list, (list(self),)

    def _take(self, twin: CanopenTwin) -> None:
        """One more twin: :meth:`Emulator.add`'s own change, on the loop."""
        list.append(self, twin)


def set_timer_slack(nanoseconds: int) -> bool:
    """Linux: the calling thread's timers may fire up to ``nanoseconds`` late (prctl
    ``PR_SET_TIMERSLACK``; the default is 50 us). True where it took; False elsewhere or where
    the C library refuses (nothing changed)."""
    if nanoseconds < 1:
        raise ValueError(f"timer slack must be >= 1 ns (0 would restore the default), "
                         f"got {nanoseconds}")
    if not sys.platform.startswith("linux"):
        return False
    try:
        prctl = ctypes.CDLL(None, use_errno=True).prctl
    except (OSError, AttributeError):
        return False
    unused = ctypes.c_ulong(0)
    return int(prctl(_PR_SET_TIMERSLACK, ctypes.c_ulong(nanoseconds), unused, unused,
                     unused)) == 0


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


class Emulator:
    """Drives ``twins`` on ``bus`` (a python-can bus, or a :class:`Port`). Powers the twins
    on at :meth:`start`. A port given stays the caller's: :meth:`stop` leaves its scheduler
    running."""

    def __init__(
        self,
        bus: can.BusABC | Port,
        twins: Iterable[CanopenTwin],
        response_delay: float = 0.0,
        notifier: can.Notifier | None = None,
        clock: Callable[[], float] = time.monotonic,
        power_up_spread: float = DEFAULT_POWER_UP_SPREAD,
    ) -> None:
        check_time("response_delay", response_delay, 0)
        #: twins powered up here boot out of phase over this many seconds (module docstring)
        self.power_up_spread = check_time("power_up_spread", power_up_spread, 0)
        taken = take_port(bus, notifier=notifier, clock=clock, name="blinkcan-emulator")
        #: the python-can bus given (None when made on a port)
        self.bus: can.BusABC | None = taken.bus
        self._owns_port = taken.owned
        self.port: Port = taken.port
        #: the port's send, bound once (every frame a twin sends goes this way)
        self._send = self.port.send
        self._twins = Twins(twins)
        self.response_delay = response_delay
        self.stats = EmulatorStats(reading=self.port.reading)
        self.scheduler: Scheduler = self.port.scheduler
        self._clock = self.scheduler.clock
        self._detach: Callable[[], None] | None = None
        self._running = False
        #: per twin: the deadline it named and the scheduler timer waiting for it
        self._deadline: list[float | None] = [None] * len(self._twins)
        self._timers: list[Timer | None] = [None] * len(self._twins)
        self._busy_until: list[float] = [0.0] * len(self._twins)
        #: replies held back by ``response_delay``: their timers, by number
        self._delayed: dict[int, Timer] = {}
        self._seq = itertools.count()
        #: standard COB-ID -> the twins that listen to it (rebuilt when any twin's routes
        #: change: ``_index_dirty``), and the COB-IDs that one twin alone listens to -> that twin
        self._index: dict[int, tuple[int, ...]] = {}
        self._sole: dict[int, tuple[int, CanopenTwin]] = {}
        self._routes_seen: list[object] = [None] * len(self._twins)
        self._index_dirty = True
        self._stuck_reported: set[int] = set()
        #: frames that could not be sent since the last one that could (logged once, counted)
        self._failing_sends = 0
        #: optional tap: ``on_frame(frame, sent, now)`` for every frame sent or received
        self.on_frame: Callable[[Frame, bool, float], object] | None = None

    @property
    def twins(self) -> Twins:
        """The twins this emulator drives, in the order given and added: a list that refuses
        changes by hand (:class:`Twins`; :meth:`add` is the way in)."""
        return self._twins

    @twins.setter
    def twins(self, twins: object) -> None:
        self._twins._refuse()

    # -- lifecycle --------------------------------------------------------------------------

    def start(self) -> Emulator:
        if self._running:
            raise RuntimeError("emulator already started")
        self._running = True
        self.scheduler.start()
        if self._owns_port and not self.scheduler.simulated:  # its own loop thread only
            self.scheduler.run(lambda: set_timer_slack(LOOP_TIMER_SLACK_NS))
        self._detach = self.port.listen(self.scheduler.deliverer(self._received))
        self.run(self._power_on_all)
        return self

    def stop(self) -> None:
        if not self._running:
            return
        self._running = False
        for timer in [*self._timers, *self._delayed.values()]:
            if timer is not None:
                timer.cancel()
        self._delayed.clear()
        if self._detach is not None:
            self._detach()
            self._detach = None
        if self._owns_port:
            self.scheduler.stop()
        failing, self._failing_sends = self._failing_sends, 0  # the loop is stopped
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
        return self.scheduler.run(partial(self._perform, action), timeout)

    def add(self, twin: CanopenTwin) -> CanopenTwin:
        """One more twin on this bus; powered on at once when the emulator runs."""

        def add_on_loop(now: float) -> list[Frame]:
            self._twins._take(twin)
            self._deadline.append(None)
            self._timers.append(None)
            self._busy_until.append(0.0)
            self._routes_seen.append(None)
            self._index_dirty = True
            if self._running:
                index = len(self._twins) - 1
                frames = self._call(index, twin.power_on, now - self._phase(twin))
                self._reschedule(index)
                self._emit(index, frames, now)
            return []

        if self._running:
            self.run(add_on_loop)
        else:
            add_on_loop(self._clock())
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
        for i, twin in enumerate(self._twins):
            frames = self._call(i, twin.power_on, now - self._phase(twin))
            self._reschedule(i)
            self._emit(i, frames, now)
        return []

    def _received(self, frame: Frame, now: float) -> None:
        """A frame from the port, on the loop (``scheduler.deliver``): to the twins. A
        standard COB-ID that one twin alone listens to goes straight to that twin (every SDO
        request comes this way); the rest, and every frame while replies are delayed, go
        through :meth:`_deliver`. The twin's own hooks see the frame either way: they are
        its routes (``twin.receive``)."""
        if not self._running:
            return
        self.stats.frames_received += 1
        if self.on_frame is not None:
            self.on_frame(frame, False, now)
        if self._index_dirty:
            self._refresh_index()
        sole = self._sole.get(frame.can_id)
        if sole is None or frame.extended or self.response_delay:
            self._deliver(frame, None, now)
            return
        # self._deliver's loop for one twin, inlined
        i, twin = sole
        try:
            replies = twin.receive(frame, now)
        except Exception as error:
            self._twin_failed(i, error)
            replies = []
        if twin.listening is not self._routes_seen[i]:
            self._index_dirty = True
        deadline = twin.next_deadline()
        if deadline != self._deadline[i]:
            self._plan(i, deadline)
        if replies:
            self._emit(i, replies, now)

    def _perform(self, action: Callable[[float], T]) -> T:
        now = self._clock()
        result = action(now)
        for i in range(len(self._twins)):
            self._reschedule(i)
        if isinstance(result, list) and all(isinstance(f, Frame) for f in result):
            self._emit(-1, result, now)  # a device's frames: every other twin may listen
        return result

    def _call(self, i: int, method: Callable[..., list[Frame]], *args: Any) -> list[Frame]:
        try:
            return method(*args)
        except Exception as error:
            self._twin_failed(i, error)
            return []

    def _twin_failed(self, i: int, error: Exception) -> None:
        self.stats.twin_errors += 1
        self.scheduler.failed(error, f"twin {self._name(i)}")

    def _deliver(self, frame: Frame, source: int | None, now: float) -> None:
        """Give ``frame`` to every twin listening to its COB-ID except its sender."""
        if frame.extended:
            targets: Iterable[int] = range(len(self._twins))
        else:
            if self._index_dirty:
                self._refresh_index()
            targets = self._index.get(frame.can_id, ())
        for i in targets:
            if i == source:
                continue
            twin = self._twins[i]
            if self.response_delay:
                if twin.is_sdo_request(frame):
                    if now < self._busy_until[i]:
                        continue  # still answering the previous request: dropped
                    self._busy_until[i] = now + self.response_delay
                replies = self._call(i, twin.receive, frame, now)
                self._reschedule(i)
                if replies:
                    key = next(self._seq)
                    self._delayed[key] = self.scheduler.call_at(
                        now + self.response_delay, partial(self._reply_due, key, i, replies))
            else:
                try:  # self._call, inlined: every frame a twin hears comes this way
                    replies = twin.receive(frame, now)
                except Exception as error:
                    self._twin_failed(i, error)
                    replies = []
                # self._reschedule(i), inlined (as self._call)
                if twin.listening is not self._routes_seen[i]:
                    self._index_dirty = True
                deadline = twin.next_deadline()
                if deadline != self._deadline[i]:
                    self._plan(i, deadline)
                if replies:
                    self._emit(i, replies, now)

    def _reply_due(self, key: int, i: int, replies: list[Frame]) -> None:
        if self._delayed.pop(key, None) is not None and self._running:
            self._emit(i, replies, self._clock())

    def _refresh_index(self) -> None:
        """Rebuild COB-ID -> twins after any twin's routes changed (a boot, a new node id)."""
        if not self._index_dirty:
            return
        self._index_dirty = False
        index: dict[int, list[int]] = {}
        for i, twin in enumerate(self._twins):
            self._routes_seen[i] = twin.listening
            for can_id in twin.listening:
                index.setdefault(can_id, []).append(i)
        self._index = {can_id: tuple(ids) for can_id, ids in index.items()}
        self._sole = {can_id: (ids[0], self._twins[ids[0]]) for can_id, ids in index.items()
                      if len(ids) == 1}

    def _emit(self, source: int, frames: list[Frame], now: float) -> None:
        send = self._send
        for frame in frames:
            try:
                send(frame)
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
            if self._index_dirty or frame.extended or frame.can_id in self._index:
                self._deliver(frame, source, now)  # to the twins that listen (often none)

    def _reschedule(self, i: int) -> None:
        """After any call into twin ``i``: its next deadline, and whether its routes changed
        (only a call into a twin can change them, so no other twin needs a look)."""
        twin = self._twins[i]
        if twin.listening is not self._routes_seen[i]:
            self._index_dirty = True
        deadline = twin.next_deadline()
        if deadline != self._deadline[i]:
            self._plan(i, deadline)

    def _plan(self, i: int, deadline: float | None) -> None:
        """Twin ``i``'s one timer waits for ``deadline`` (None: no timer)."""
        self._deadline[i] = deadline
        timer = self._timers[i]
        if timer is not None:
            timer.cancel()
        self._timers[i] = (None if deadline is None or not self._running else
                           self.scheduler.call_at(deadline, partial(self._due, i, deadline)))

    def _due(self, i: int, deadline: float) -> None:
        """Twin ``i``'s deadline came: ``advance`` it, send what it sends, then plan its next
        deadline (the bookkeeping after the frames: they are what is late)."""
        if deadline != self._deadline[i] or not self._running:
            return
        self._timers[i] = None
        now = self._clock()
        twin = self._twins[i]
        try:  # self._call, inlined: every periodic frame comes this way
            frames = twin.advance(now)
        except Exception as error:
            self._twin_failed(i, error)
            frames = []
        if twin.listening is not self._routes_seen[i]:  # before the frames are delivered
            self._index_dirty = True
        if frames:
            self._emit(i, frames, now)
            self.stats.lateness.append(now - deadline)
            if self._timers[i] is not None or not self._running:
                return  # the frames' delivery replanned twin i (its replies reached it)
        # self._reschedule and self._plan, inlined (the timer that ran is gone already)
        following = twin.next_deadline()
        if following is None or following <= now:  # <= now: advance(now) left it due
            self._deadline[i] = None
            if following is not None:
                self._stuck(i, now)  # asking again at once would spin
            return
        self._deadline[i] = following
        self._timers[i] = self.scheduler.call_at(following, partial(self._due, i, following))

    def _stuck(self, i: int, now: float) -> None:
        """Twin ``i`` named a deadline that ``advance(now)`` did not consume."""
        deadline = self._twins[i].next_deadline()
        message = (f"twin {self._name(i)} names deadline t={deadline!r} s that advance() at "
                   f"t={now!r} s did not consume: time could not move past it")
        if self.scheduler.simulated:
            raise StuckDeadlineError(message)  # the simulation would spin here for ever
        if i not in self._stuck_reported:  # once per twin: it is asked again every retry
            self._stuck_reported.add(i)
            log.error("%s; asking it again every %g s", message, _STUCK_RETRY_S)
        self._plan(i, now + _STUCK_RETRY_S)

    def _phase(self, twin: CanopenTwin) -> float:
        spread = self.power_up_spread
        return power_up_phase(twin.node_id, spread) if spread else 0.0

    def _name(self, i: int) -> str:
        twin = self._twins[i]
        return f"{type(twin).__name__} at node {twin.node_id:02X}h"
