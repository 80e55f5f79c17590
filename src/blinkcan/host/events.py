"""Events from drivers, as callbacks or an iterator (a queue per iteration).

A callback that raises is logged and the others still get the event; under simulated time
(``blinkcan.testing``) the exception is then raised from the call that ran the simulation.
``close()`` ends every iterator. On a simulated bus (a ``Rig``) an iterator waiting for its next
event runs the simulation, and one with no timeout ends after :data:`SIMULATED_FOREVER` virtual
seconds without an event: nothing else would ever end it (the thread that waits is the one that
runs the simulation), and a busy rig's hour of traffic took most of a test's wall-time limit.
"""

from __future__ import annotations

import logging
import queue
import threading
from collections.abc import Callable, Iterator
from typing import Generic, TypeVar

from blinkcan.runtime.scheduler import Scheduler
from blinkcan.runtime.virtual_waits import LONGEST_VIRTUAL_WAIT, RECV_FOREVER

log = logging.getLogger(__name__)
E = TypeVar("E")
_CLOSED = object()


#: virtual seconds an iterator with no timeout waits at most for its next event on a simulated
#: bus: a simulated wait always ends (nothing else would ever move the clock). The bound of every
#: wait with no timeout on a rig, ``rig.bus.recv()`` and cantools' ``Tester.expect`` too: one
#: number to know (README, Testing); a longer wait names its timeout
SIMULATED_FOREVER = RECV_FOREVER

#: the longest timeout an event iterator takes, in seconds (an hour; virtual ones on a rig):
#: a longer one ran a busy rig's simulation that long (``timeout=1e308`` never ended) and made
#: ``queue.get`` raise OverflowError on a real bus. Wait longer with no timeout (None)
LONGEST_EVENT_WAIT = LONGEST_VIRTUAL_WAIT


def check_event_timeout(timeout: float | None) -> float | None:
    """Return ``timeout`` if it is None or a number of seconds from 0 to
    :data:`LONGEST_EVENT_WAIT`; else TypeError/ValueError naming that range (NaN, negative,
    infinite or longer timeouts are bad arguments)."""
    if timeout is None:
        return None
    if isinstance(timeout, bool) or not isinstance(timeout, (int, float)):
        raise TypeError(f"timeout must be a number of seconds or None, "
                        f"not {type(timeout).__name__}")
    if not 0 <= timeout <= LONGEST_EVENT_WAIT:  # NaN too
        raise ValueError(f"timeout must be from 0 to {LONGEST_EVENT_WAIT:g} seconds "
                         f"(None: no timeout), not {timeout!r}")
    return timeout


class _Holds:
    """A signal that is set while ``ready()`` holds (for simulated waits)."""

    def __init__(self, ready: Callable[[], object]) -> None:
        self._ready = ready

    def set(self) -> None:
        """Set by what ``ready`` reads."""

    def clear(self) -> None:
        """Cleared by what ``ready`` reads."""

    def is_set(self) -> bool:
        return bool(self._ready())


class EventSource(Generic[E]):
    """Callbacks run on the bus thread; :meth:`iterate` hands events to any other thread."""

    def __init__(self, scheduler: Scheduler | None = None) -> None:
        self._callbacks: list[Callable[[E], object]] = []
        self._queues: list[queue.SimpleQueue[E | object]] = []
        self._lock = threading.Lock()
        self._scheduler = scheduler
        self.closed = False

    def subscribe(self, callback: Callable[[E], object]) -> Callable[[], None]:
        self._callbacks.append(callback)
        return lambda: self._callbacks.remove(callback) if callback in self._callbacks else None

    def emit(self, event: E) -> None:
        for callback in list(self._callbacks):
            try:
                callback(event)
            except Exception as error:
                what = f"an event callback (the other subscribers still get {event!r})"
                if self._scheduler is not None:
                    self._scheduler.failed(error, what)
                else:
                    log.error("%s raised", what, exc_info=error)
        with self._lock:
            for waiting in self._queues:
                waiting.put(event)

    def close(self) -> None:
        """No more events: every iterator ends (after the events already queued)."""
        self.closed = True
        with self._lock:
            for waiting in self._queues:
                waiting.put(_CLOSED)

    @property
    def simulated(self) -> bool:
        """Whether the driver runs in simulated time: waiting for an event then runs the
        simulation (:meth:`run_until`), since nothing else would."""
        return self._scheduler is not None and self._scheduler.simulated

    def run_until(self, ready: Callable[[], object], timeout: float | None) -> bool:
        """Simulated time only: run the simulation until ``ready()`` holds (True) or
        ``timeout`` virtual seconds passed (None: :data:`SIMULATED_FOREVER`; False)."""
        scheduler = self._scheduler
        if scheduler is None or not scheduler.simulated:
            raise RuntimeError("run_until runs a simulation: this driver is on a real bus")
        limit = SIMULATED_FOREVER if timeout is None else timeout
        return scheduler.wait(_Holds(ready), limit, background=True)

    def iterate(self, timeout: float | None = None) -> Iterator[E]:
        """Events from the moment of this call (not of the first ``next``); the iterator ends
        after ``timeout`` seconds without one (None: never on a real bus, after
        :data:`SIMULATED_FOREVER` virtual seconds on a simulated one; else 0 to
        :data:`LONGEST_EVENT_WAIT`: ValueError at this call) and when the source closes."""
        check_event_timeout(timeout)
        waiting: queue.SimpleQueue[E | object] = queue.SimpleQueue()
        with self._lock:
            if self.closed:
                waiting.put(_CLOSED)
            self._queues.append(waiting)
        return self._drain(waiting, timeout)

    def _next(self, waiting: queue.SimpleQueue[E | object], timeout: float | None) -> object:
        if self.simulated and waiting.empty():
            self.run_until(lambda: not waiting.empty(), timeout)
            return waiting.get_nowait()
        return waiting.get(timeout=timeout)

    def _drain(self, waiting: queue.SimpleQueue[E | object], timeout: float | None
               ) -> Iterator[E]:
        try:
            while True:
                try:
                    item = self._next(waiting, timeout)
                except queue.Empty:
                    return
                if item is _CLOSED:
                    return
                yield item  # type: ignore[misc]
        finally:
            with self._lock:
                self._queues.remove(waiting)
