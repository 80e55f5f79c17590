"""One scheduling abstraction for twins and drivers: timers, calls on the owning loop, waiting.

Two implementations share one interface:

- :class:`RealTimeScheduler`: an owning thread, a queue for other threads' calls and a timer
  heap on ``time.monotonic``; a frame a reader thread delivers while the loop is idle runs at
  once on that thread, which holds the loop meanwhile (no thread hop per frame). This is what
  runs on real buses (and python-can's ``virtual``).
- :class:`SimulatedScheduler`: no thread and no sleeping. A virtual clock jumps from one due
  event to the next; events due at the same instant run in the order they were scheduled, so a
  scenario gives the same frames at the same times on every run. A caller that waits (a driver
  waiting for its SDO reply) runs the simulation itself until what it waits for happened or its
  virtual timeout passed.

Everything that waits goes through :meth:`Scheduler.wait` on a :class:`Signal` made by the same
scheduler, and blocking work that must leave a handler goes through :meth:`Scheduler.spawn`,
so drivers are written once for both kinds of time.

An exception raised in a handler, a timer or spawned work (:meth:`Scheduler.guarded`): in real
time it is logged with its traceback and the loop goes on (a controller keeps running); in
simulated time it is raised again, with its traceback, from the call that drove the simulation
when it happened (``rig.tap``, ``rig.advance``, a driver call waiting for its reply), so the
test that caused it fails.

Times are checked: a non-finite time or timeout is a ValueError (a NaN deadline never comes and
never passes, so it would hang a simulation).
"""

from __future__ import annotations

import collections
import heapq
import itertools
import logging
import math
import queue
import threading
import time
from abc import ABC, abstractmethod
from collections.abc import Callable, Hashable
from concurrent.futures import Future, ThreadPoolExecutor
from functools import partial
from threading import get_ident
from typing import Any, Protocol, TypeVar

from blinkcan.errors import BlinkcanError
from blinkcan.protocol.cob import check_time

log = logging.getLogger(__name__)
T = TypeVar("T")

_STOP = object()
_POSTED = object()
#: the argument of a timer's entry in the simulated scheduler's queue of calls due now
_TIMER = object()
_MAX_IDLE_WAIT = 0.5
#: the longest timeout a wait on a simulated bus takes, in virtual seconds (an hour): a busy
#: rig simulates an hour in under a minute of wall time, but ``timeout=1e308`` ran for ever, and
#: a driver's SDO timeout of a day (its bound on a real bus) took minutes. One bound for every
#: wait in virtual time: the drivers' (here), ``rig.until``, the event iterators,
#: ``SimulatedBus.recv`` and the libraries' waits (``runtime.virtual_waits``)
LONGEST_VIRTUAL_WAIT = 3600.0
_WORKERS = 4  # blocking work (SDO off a handler) per scheduler: bounded, never one per call


def check_virtual_timeout(timeout: float) -> float:
    """``timeout`` if it is a number of virtual seconds up to :data:`LONGEST_VIRTUAL_WAIT`
    (one not above 0 waits for nothing); else TypeError/ValueError naming that range."""
    if isinstance(timeout, bool) or not isinstance(timeout, (int, float)):
        raise TypeError(f"timeout must be a number of seconds, not {type(timeout).__name__}")
    if not timeout <= LONGEST_VIRTUAL_WAIT:  # NaN and infinity too
        raise ValueError(f"timeout must be at most {LONGEST_VIRTUAL_WAIT:g} virtual seconds on "
                         f"a simulated bus, not {timeout!r}")
    return timeout


class Signal(Protocol):
    """Something a caller waits for: set once the awaited thing happened."""

    def set(self) -> None: ...

    def clear(self) -> None: ...

    def is_set(self) -> bool: ...


class Flag:
    """A :class:`Signal` for one thread: a simulated scheduler's waits poll it."""

    __slots__ = ("_set",)

    def __init__(self) -> None:
        self._set = False

    def set(self) -> None:
        self._set = True

    def clear(self) -> None:
        self._set = False

    def is_set(self) -> bool:
        return self._set


class Wakeup:
    """A :class:`Signal` for threads, set from any thread, waking every waiter: a lock that
    is released while set. Lighter than ``threading.Event`` (no condition, no lock made per
    wait): every SDO request of a driver waits on one."""

    __slots__ = ("_unset",)

    def __init__(self) -> None:
        self._unset = threading.Lock()
        self._unset.acquire()

    def set(self) -> None:
        try:  # noqa: SIM105 (every SDO reply passes here: suppress() costs a context manager)
            self._unset.release()
        except RuntimeError:  # set already
            pass

    def clear(self) -> None:
        self._unset.acquire(False)  # not blocking (positional: a keyword costs more, per request)

    def is_set(self) -> bool:
        return not self._unset.locked()

    def wait(self, timeout: float) -> bool:
        """True once set, False after ``timeout`` seconds."""
        unset = self._unset
        if not (unset.acquire(True, timeout) if timeout > 0 else unset.acquire(False)):
            return False
        try:  # noqa: SIM105 (as in set)
            unset.release()  # it stays set: every other waiter wakes too
        except RuntimeError:  # set again meanwhile
            pass
        return True


class Timer:
    """A scheduled call; :meth:`cancel` stops it (and its repetitions). A repeating timer is
    due at ``origin + count x period`` (no float sums that drift), each time strictly later."""

    __slots__ = ("callback", "cancelled", "count", "due", "origin", "period")

    def __init__(self, due: float, period: float | None, callback: Callable[[], object]) -> None:
        self.due = due
        self.period = period
        self.callback = callback
        self.cancelled = False
        self.origin = due
        self.count = 0

    def rearm(self, now: float) -> None:
        """The next due time of a repeating timer that ran at ``now``: the next multiple of
        the period, or ``now`` once when it ran late (then every period from there)."""
        assert self.period is not None
        self.count += 1
        due = self.origin + self.count * self.period
        if due <= now:
            self.origin, self.count, due = now, 0, now
        if due <= self.due:  # a period below the clock's resolution: time still moves
            due = math.nextafter(self.due, math.inf)
        self.due = due

    def cancel(self) -> None:
        self.cancelled = True


_new_timer = object.__new__  # a Timer without the call of its __init__ (set every slot)


def guarded(callback: Callable[..., object], *args: object) -> None:
    """Run a handler; an exception is logged with its traceback and the loop goes on (the
    real-time rule; :meth:`Scheduler.guarded` follows the scheduler's rule)."""
    try:
        callback(*args)
    except Exception:
        log.exception("a blinkcan handler raised; the loop goes on")


class WrongThreadError(BlinkcanError, RuntimeError):
    """A call that runs a simulation, or sends on it, came from another thread than the one
    that owns it (a Rig's: the thread that made it)."""

    @classmethod
    def of(cls, doing: str, owner: threading.Thread) -> WrongThreadError:
        return cls(f"{doing} from thread {threading.current_thread().name!r}: the simulation "
                   f"runs in the thread that made the Rig ({owner.name!r}), and would run "
                   "(and move its clock) under it. Call the drivers from that thread, and "
                   "run asyncio code in an event loop of that thread (asyncio.run in the test)")


class StuckDeadlineError(BlinkcanError, RuntimeError):
    """A simulation would spin: a twin names a deadline that ``advance()`` at that time does
    not consume, so virtual time could never move past it."""


class Scheduler(ABC):
    """Timers and calls on one owning loop, with a clock that is real or simulated."""

    simulated: bool = False

    @abstractmethod
    def clock(self) -> float:
        """Seconds, monotonic: wall time or virtual time."""

    def guarded(self, callback: Callable[..., object], *args: object,
                what: str = "a blinkcan handler") -> None:
        """Run a handler, a timer or spawned work; an exception goes to :meth:`failed`."""
        try:
            callback(*args)
        except Exception as error:
            self.failed(error, what)

    def failed(self, error: Exception, what: str = "a blinkcan handler") -> None:
        """``what`` raised ``error``: logged with its traceback, and the loop goes on."""
        log.error("%s raised; the loop goes on", what, exc_info=error)

    @abstractmethod
    def _push(self, timer: Timer) -> Timer:
        """Put ``timer`` on the heap (from any thread)."""

    @abstractmethod
    def run(self, action: Callable[[], T], timeout: float = 5.0) -> T:
        """Run ``action`` on the loop and return its result (at once when already there)."""

    @abstractmethod
    def signal(self) -> Signal:
        """A fresh signal that :meth:`wait` can wait for."""

    @abstractmethod
    def wait(self, signal: Signal, timeout: float, background: bool = False) -> bool:
        """Block the caller until ``signal`` is set (True) or ``timeout`` s passed (False).
        ``background``: spawned work may run meanwhile (waiting for events, not in the middle
        of a transfer)."""

    @abstractmethod
    def sleep(self, seconds: float) -> None:
        """Let ``seconds`` of this scheduler's time pass (the simulation runs meanwhile)."""

    @abstractmethod
    def spawn(self, action: Callable[[], object], key: Hashable | None = None) -> None:
        """Run blocking work (SDO transfers) outside the handlers; work with a ``key`` still
        pending is not queued twice (a slow device never piles up polls)."""

    @property
    @abstractmethod
    def in_loop(self) -> bool:
        """True when called from the loop itself (a handler or timer)."""

    @abstractmethod
    def start(self) -> None:
        """Start the loop (a no-op where the caller drives it)."""

    @abstractmethod
    def stop(self) -> None:
        """Stop the loop; calls still queued fail."""

    def call_at(self, when: float, callback: Callable[[], object]) -> Timer:
        if when.__class__ is not float or when - when:  # not a finite float: check it
            check_time("when", when)
        return self._push(Timer(when, None, callback))

    def post(self, callback: Callable[[], object]) -> None:
        """Run ``callback`` on the loop as soon as it can, after what was posted before
        (from any thread; cheaper than a timer: frames from the reader come this way)."""
        self.call_soon(callback)

    def deliver(self, callback: Callable[..., object], *args: object) -> None:
        """Run ``callback(*args)`` on the loop, from a port's receiving context (a frame):
        at once when already there, else as soon as it can, after what was posted before."""
        if self.in_loop:
            callback(*args)
        else:
            self.post(partial(callback, *args))

    def deliverer(self, callback: Callable[..., object]) -> Callable[..., None]:
        """:meth:`deliver` with ``callback`` bound: the one call a port makes per frame for a
        receiver that runs on the loop (bound once, where the receiver starts listening)."""
        return partial(self.deliver, callback)

    def call_later(self, delay: float, callback: Callable[[], object]) -> Timer:
        return self._push(Timer(self.clock() + check_time("delay", delay), None, callback))

    def call_soon(self, callback: Callable[[], object]) -> Timer:
        return self._push(Timer(self.clock(), None, callback))

    def call_every(self, period: float, callback: Callable[[], object], first: float = 0.0
                   ) -> Timer:
        check_time("period", period)
        check_time("first", first)
        if period <= 0:
            raise ValueError(f"period must be > 0 seconds, got {period}")
        return self._push(Timer(self.clock() + first, period, callback))


class _Heap:
    """Due timers in order of time, then of scheduling (so equal times keep their order)."""

    def __init__(self) -> None:
        self.entries: list[tuple[float, int, Timer]] = []
        #: the order of scheduling (shared with the simulated scheduler's calls due now)
        self.sequence = itertools.count()

    def push(self, timer: Timer) -> None:
        heapq.heappush(self.entries, (timer.due, next(self.sequence), timer))

    def next_due(self) -> float | None:
        entries = self.entries
        while entries and entries[0][2].cancelled:
            heapq.heappop(entries)
        return entries[0][0] if entries else None

    def pop_due(self, now: float) -> Timer | None:
        """The next timer due by ``now`` (re-armed first if it repeats), or None."""
        entries = self.entries
        while entries and entries[0][0] <= now:
            _, _, timer = heapq.heappop(entries)
            if timer.cancelled:
                continue
            if timer.period is not None:
                timer.rearm(now)
                self.push(timer)
            return timer
        return None


class RealTimeScheduler(Scheduler):
    """An owning loop on the wall clock: a thread of its own runs the timers and the calls
    other threads post; a frame from a reader thread runs at once on that thread when the
    loop is idle (:meth:`deliver`). Whoever runs the loop's work holds the loop meanwhile,
    so that work stays one call at a time, in order, as on one thread."""

    def __init__(self, name: str = "blinkcan", clock: Callable[[], float] = time.monotonic
                 ) -> None:
        self.name = name
        self._clock = clock
        #: wakes the loop: timers to schedule, a call posted, the stop
        self._inbox: queue.SimpleQueue[Any] = queue.SimpleQueue()
        #: calls posted and actions to run, in order: ``(callback, None)``, ``(action, future)``
        self._calls: collections.deque[tuple[Callable[[], Any], Future[Any] | None]] = (
            collections.deque())
        #: held by the thread that runs the loop's work (its thread, or a reader delivering)
        self._held = threading.Lock()
        self._owner: int | None = None
        self._heap = _Heap()
        self._thread: threading.Thread | None = None
        self._workers: ThreadPoolExecutor | None = None
        self._pending: set[Hashable] = set()
        self._pending_lock = threading.Lock()

    def clock(self) -> float:
        return self._clock()

    @property
    def running(self) -> bool:
        return self._thread is not None

    @property
    def in_loop(self) -> bool:
        return self._owner == get_ident()

    def start(self) -> None:
        if self._thread is None:
            self._thread = threading.Thread(target=self._loop, name=self.name, daemon=True)
            self._thread.start()

    def stop(self) -> None:
        thread, self._thread = self._thread, None
        if thread is None:
            return
        self._inbox.put(_STOP)
        if not self.in_loop and threading.current_thread() is not thread:
            thread.join(timeout=5)
        if self._workers is not None:
            self._workers.shutdown(wait=False, cancel_futures=True)
            self._workers = None
        while True:  # calls still queued will never run: fail them now
            try:
                _, future = self._calls.popleft()
            except IndexError:
                break
            if future is not None:
                future.set_exception(RuntimeError(f"{self.name} was stopped"))
        while True:
            try:
                self._inbox.get_nowait()
            except queue.Empty:
                break

    def _push(self, timer: Timer) -> Timer:
        self._inbox.put(timer)
        return timer

    def post(self, callback: Callable[[], object]) -> None:
        self._calls.append((callback, None))
        self._inbox.put(_POSTED)

    def deliver(self, callback: Callable[..., object], *args: object) -> None:
        """Run ``callback(*args)`` on the loop: at once on this thread when it is the loop's
        or the loop is idle with nothing posted before (this thread holds the loop
        meanwhile: no thread hop), else posted. An exception reaches the caller."""
        self.deliverer(callback)(*args)

    def deliverer(self, callback: Callable[..., object]) -> Callable[..., None]:
        """:meth:`deliver` with ``callback`` bound, as one function of the frame's arguments:
        a port calls it per frame (no partial, no method call, the loop's lock and queue
        bound once: every SDO request an emulator answers comes this way)."""
        calls, acquire, release = self._calls, self._held.acquire, self._held.release

        def deliver(*args: object) -> None:
            me = get_ident()
            if self._owner == me:
                callback(*args)
                return
            if self._thread is not None and not calls and acquire(False):
                try:
                    if not calls:  # nothing posted before still waits: order kept
                        self._owner = me
                        try:
                            callback(*args)
                        finally:
                            self._owner = None
                        return
                finally:
                    release()
            self.post(partial(callback, *args))

        return deliver

    def run(self, action: Callable[[], T], timeout: float = 5.0) -> T:
        if self._thread is None or self.in_loop:
            return action()
        future: Future[T] = Future()
        self._calls.append((action, future))
        self._inbox.put(_POSTED)
        return future.result(timeout)

    def signal(self) -> Signal:
        return Wakeup()

    def wait(self, signal: Signal, timeout: float, background: bool = False) -> bool:
        if timeout.__class__ is not float or timeout - timeout:  # not a finite float: check
            check_time("timeout", timeout)
        # a Wakeup (what signal() makes) or a threading.Event: no isinstance, every SDO
        # request waits here
        return signal.wait(timeout)  # type: ignore[attr-defined,no-any-return]

    def sleep(self, seconds: float) -> None:
        time.sleep(check_time("seconds", seconds, 0))

    def spawn(self, action: Callable[[], object], key: Hashable | None = None) -> None:
        if key is not None:
            with self._pending_lock:
                if key in self._pending:
                    return
                self._pending.add(key)
        if self._workers is None:
            self._workers = ThreadPoolExecutor(_WORKERS, thread_name_prefix=f"{self.name}-work")

        def work() -> None:
            try:
                self.guarded(action, what="work handed to spawn")
            finally:  # the same work is not queued again until this one is over
                if key is not None:
                    with self._pending_lock:
                        self._pending.discard(key)

        try:
            self._workers.submit(work)
        except RuntimeError:  # shut down meanwhile
            log.debug("%s: work dropped, the scheduler is stopped", self.name)

    def _loop(self) -> None:
        inbox, heap, calls, held = self._inbox, self._heap, self._calls, self._held
        me = get_ident()
        held.acquire()
        self._owner = me
        try:
            while True:
                due = heap.next_due()
                wait = _MAX_IDLE_WAIT if due is None else due - self._clock()
                item: Any = None
                if wait > 0 and not calls:  # idle: a reader may deliver meanwhile
                    self._owner = None
                    held.release()
                    try:
                        item = inbox.get(timeout=min(wait, _MAX_IDLE_WAIT))
                    except queue.Empty:
                        item = None
                    finally:
                        held.acquire()
                        self._owner = me
                stop = False
                while True:
                    if item is _STOP:
                        stop = True
                    elif isinstance(item, Timer):
                        heap.push(item)
                    try:
                        item = inbox.get_nowait()
                    except queue.Empty:
                        break
                while calls and not stop:
                    self._run_call(*calls.popleft())
                if stop:
                    return
                now = self._clock()
                while (timer := heap.pop_due(now)) is not None:
                    self.guarded(timer.callback)
        finally:
            self._owner = None
            held.release()

    def _run_call(self, action: Callable[[], Any], future: Future[Any] | None) -> None:
        if future is None:
            self.guarded(action)
            return
        try:
            future.set_result(action())
        except BaseException as error:
            future.set_exception(error)


class SimulatedScheduler(Scheduler):
    """Virtual time: one thread (the caller's), events in order, the clock jumps between them.

    Not thread-safe by design: the thread that calls it (the test) is the loop. Blocking work
    handed to :meth:`spawn` runs when no one is waiting, so it never interleaves with a
    transfer the caller is in the middle of. An exception in a handler, timer or spawned work
    is raised again from the outermost call that runs the simulation (see the module
    docstring), once the handler that raised it returned.
    """

    simulated = True

    def __init__(self, start: float = 0.0) -> None:
        #: the virtual time, what :meth:`clock` returns (read it, never set it: the wire reads
        #: it for every frame, where a call costs more than the rest of the read)
        self.now = check_time("start", start)
        self._failures: list[tuple[Exception, str]] = []
        #: timers due later than the clock, in order of time, then of scheduling
        self._heap = _Heap()
        self._sequence = self._heap.sequence
        #: what is due now, in the order it was scheduled: ``(callback, argument)`` from
        #: :meth:`defer`, ``(timer, _TIMER)`` for a timer. The heap's timers join it when the
        #: clock reaches their time, all of that time at once, before anything runs then, so
        #: everything due at one instant runs in scheduling order with no sequence to compare
        self._ready: collections.deque[tuple[Any, Any]] = collections.deque()
        self._depth = 0  # handlers running (waits inside them nest)
        self._base = 0  # depth at which the running background work started
        self._waits = 0
        self._background: collections.deque[tuple[Hashable | None, Callable[[], object]]] = (
            collections.deque())
        self._in_background = False  # a piece of spawned work is running
        #: the one thread that may run the simulation (a Rig's), None: any
        self.owner: threading.Thread | None = None

    def clock(self) -> float:
        return self.now

    def start(self) -> None:
        """Nothing to start: the callers drive the simulation."""

    def stop(self) -> None:
        """Nothing to stop; pending events stay (the simulation may go on)."""

    @property
    def in_loop(self) -> bool:
        return self._depth > self._base

    def _push(self, timer: Timer) -> Timer:
        if timer.due <= self.now:  # due now (or late): after what is already due now
            timer.due = self.now
            self._ready.append((timer, _TIMER))
        else:
            self._heap.push(timer)
        return timer

    def call_at(self, when: float, callback: Callable[[], object]) -> Timer:
        # Scheduler.call_at with _push and Timer.__init__ inlined: the emulator plans every
        # twin deadline here
        if when.__class__ is not float or when - when:  # not a finite float: check it
            check_time("when", when)
        timer = _new_timer(Timer)
        timer.due = timer.origin = when
        timer.period = None
        timer.callback = callback
        timer.cancelled = False
        timer.count = 0
        if when <= self.now:
            timer.due = self.now
            self._ready.append((timer, _TIMER))
        else:
            heapq.heappush(self._heap.entries, (when, next(self._sequence), timer))
        return timer

    def deliver(self, callback: Callable[..., object], *args: object) -> None:
        """Run ``callback(*args)`` at once: a simulated port's frames are handed over by the
        simulation, inside it."""
        callback(*args)

    def defer(self, callback: Callable[[Any], object], argument: Any) -> None:
        """``call_soon(lambda: callback(argument))``, without a timer to cancel: the simulated
        wire hands every frame over this way, and a timer and a closure per frame cost more
        than the rest of its delivery. It runs at the time it was made (the clock moves only
        once everything due now has run)."""
        self._ready.append((callback, argument))

    def deferrer(self) -> Callable[[tuple[Callable[[Any], object], Any]], None]:
        """:meth:`defer` as one call taking the pair ``(callback, argument)``: the queue's own
        append, for the wire's path of every frame."""
        return self._ready.append

    def deferred(self) -> list[tuple[Callable[[Any], object], Any]]:
        """The calls :meth:`defer` made that have not run yet, in order."""
        return [(callback, argument) for callback, argument in self._ready
                if argument is not _TIMER]

    def run(self, action: Callable[[], T], timeout: float = 5.0) -> T:
        return action()

    def signal(self) -> Signal:
        return Flag()

    def wait(self, signal: Signal, timeout: float, background: bool = False) -> bool:
        """As :meth:`Scheduler.wait`, in virtual time: ``timeout`` up to
        :data:`LONGEST_VIRTUAL_WAIT`, else a ValueError before the simulation runs."""
        check_time("timeout", check_virtual_timeout(timeout))  # -inf too
        if background:
            return self.run_until(signal.is_set, self.now + timeout)
        self._waits += 1
        try:
            return self.run_until(signal.is_set, self.now + timeout)
        finally:
            self._waits -= 1
            if not self._waits and self._background:
                self.call_soon(self._run_background)

    def sleep(self, seconds: float) -> None:
        self.run_until(None, self.now + check_time("seconds", seconds, 0))

    def spawn(self, action: Callable[[], object], key: Hashable | None = None) -> None:
        if key is not None and any(key == pending for pending, _ in self._background):
            return
        self._background.append((key, action))
        self.call_soon(self._run_background)

    def _run_background(self) -> None:
        """Run the next piece of work handed to :meth:`spawn`; never one inside another.

        Work that waits (a driver's blocking call) runs the simulation, and a timer firing
        meanwhile may spawn more (a periodic poll). Each piece has its own turn after the
        events already due, so the caller's ``until`` is looked at between two pieces and
        virtual time cannot run away in nested or queued waits."""
        if self._waits or self._in_background or not self._background:
            return  # the wait's end, or the running piece's end, schedules this again
        _, action = self._background.popleft()
        self._in_background = True
        base, self._base = self._base, self._depth
        try:
            self.guarded(action, what="work handed to spawn")
        finally:
            self._base = base
            self._in_background = False
            if self._background and not self._waits:
                self.call_soon(self._run_background)

    def next_due(self) -> float | None:
        due = self._heap.next_due()
        return self.now if self._ready else due  # a deferred call is due now

    def failed(self, error: Exception, what: str = "a blinkcan handler") -> None:
        """Kept, and raised again by the call that drives the simulation."""
        self._failures.append((error, what))

    def raise_failures(self) -> None:
        """Raise the first exception a handler raised since the last call (the others are
        logged), with its traceback; nothing when none did."""
        if not self._failures:
            return
        failures, self._failures = self._failures, []
        for error, what in failures[1:]:
            log.error("%s also raised at t=%.6f", what, self.now, exc_info=error)
        raise failures[0][0]

    def _next_instant(self, until: float) -> bool:
        """Move the clock to the next time a timer is due, if it is by ``until``: the timers
        due then join the queue of what is due now, in order. False when there is none (the
        clock stays)."""
        entries = self._heap.entries
        while entries and entries[0][2].cancelled:
            heapq.heappop(entries)
        if not entries or entries[0][0] > until:
            return False
        due = entries[0][0]
        if due > self.now:  # noqa: PLR1730 (max() is a call: this runs per instant)
            self.now = due
        ready = self._ready
        while entries and entries[0][0] <= due:
            timer = heapq.heappop(entries)[2]
            if not timer.cancelled:
                ready.append((timer, _TIMER))
        return True

    def _take(self, timer: Timer) -> Callable[[], object] | None:
        """A timer's turn came: its callback (None when cancelled meanwhile), a repeating one
        re-armed first."""
        if timer.cancelled:
            return None
        if timer.period is not None:
            timer.rearm(self.now)
            self._push(timer)
        return timer.callback

    def _run(self, callback: Callable[..., object], args: tuple[object, ...]) -> None:
        """Run one event; an exception its handlers raised is raised here once they are done
        (:meth:`Scheduler.guarded`, inlined: this runs for every event)."""
        self._depth += 1
        try:
            callback(*args)
        except Exception as error:
            self.failed(error)
        finally:
            self._depth -= 1
        if not self._depth and self._failures:
            self.raise_failures()

    def step(self, until: float) -> bool:
        """Run the next event due by ``until``; False when there is none (the clock stays).
        An exception the event's handlers raised is raised here once they are done."""
        if until - until and until != math.inf:  # NaN or -inf (+inf: no end)
            check_time("until", until, infinite=True)
        ready = self._ready
        while True:
            if ready and self.now <= until:
                callback, argument = ready.popleft()
                if argument is not _TIMER:
                    self._run(callback, (argument,))
                    return True
                action = self._take(callback)
                if action is not None:
                    self._run(action, ())
                    return True
            elif not self._next_instant(until):
                return False

    def run_until(self, predicate: Callable[[], object] | None, until: float) -> bool:
        """Run events in order until ``predicate()`` is true (True) or the clock reaches
        ``until`` (False; the clock then stands at ``until``; +inf: no end).
        :class:`WrongThreadError` from another thread than :attr:`owner`'s."""
        if self.owner is not None and get_ident() != self.owner.ident:
            raise WrongThreadError.of("a wait on the simulated bus", self.owner)
        check_time("until", until, infinite=True)
        ready, next_instant, mark = self._ready, self._next_instant, _TIMER
        popleft = ready.popleft
        while True:
            if predicate is not None and predicate():
                met = True
                break
            if not (ready and self.now <= until):
                if next_instant(until):
                    continue
                if until != math.inf:  # with no end given, the clock stays at the last event
                    self.now = max(self.now, until)
                met = bool(predicate()) if predicate is not None else True
                break
            # step() and _run(), inlined: this loop runs every event of a simulation. With no
            # predicate to ask between events, everything due now runs in one go, inside one
            # depth (in_loop): no one looks between two of them
            self._depth += 1
            try:
                while True:
                    callback, argument = popleft()
                    if argument is not mark:
                        try:
                            callback(argument)
                        except Exception as error:
                            self.failed(error)
                    elif not callback.cancelled:  # a timer
                        if callback.period is not None:
                            callback.rearm(self.now)
                            self._push(callback)
                        try:
                            callback.callback()
                        except Exception as error:
                            self.failed(error)
                    if predicate is not None or not ready or self._failures or self.now > until:
                        break
            finally:
                self._depth -= 1
            if not self._depth and self._failures:
                self.raise_failures()
        if not self._depth:
            self.raise_failures()
        return met
