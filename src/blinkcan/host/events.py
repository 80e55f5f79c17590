"""Events from drivers, as callbacks or an iterator (a queue per iteration).

A callback that raises is logged and the others still get the event; under simulated time
(``blinkcan.testing``) the exception is then raised from the call that ran the simulation.
``close()`` ends every iterator. On a simulated bus an iterator waiting for its next event runs
the simulation.
"""

from __future__ import annotations

import logging
import queue
import threading
from collections.abc import Callable, Iterator
from typing import Generic, TypeVar

from blinkcan.runtime.scheduler import Scheduler

log = logging.getLogger(__name__)
E = TypeVar("E")
_CLOSED = object()


class _Arrived:
    """A signal that is set while ``waiting`` holds an event (for simulated waits)."""

    def __init__(self, waiting: queue.SimpleQueue[object]) -> None:
        self._waiting = waiting

    def set(self) -> None:
        """Set by the queue itself."""

    def clear(self) -> None:
        """Cleared by taking the event."""

    def is_set(self) -> bool:
        return not self._waiting.empty()


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

    def iterate(self, timeout: float | None = None) -> Iterator[E]:
        """Events from the moment of this call (not of the first ``next``); the iterator ends
        after ``timeout`` seconds without one (None: never) and when the source closes."""
        waiting: queue.SimpleQueue[E | object] = queue.SimpleQueue()
        with self._lock:
            if self.closed:
                waiting.put(_CLOSED)
            self._queues.append(waiting)
        return self._drain(waiting, timeout)

    def _next(self, waiting: queue.SimpleQueue[E | object], timeout: float | None) -> object:
        scheduler = self._scheduler
        if scheduler is not None and scheduler.simulated and waiting.empty():
            limit = 3600.0 if timeout is None else timeout  # a simulated wait always ends
            scheduler.wait(_Arrived(waiting), limit, background=True)
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
