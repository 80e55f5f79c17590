"""Events from drivers, as callbacks or an iterator (a queue per iteration)."""

from __future__ import annotations

import queue
import threading
from collections.abc import Callable, Iterator
from typing import Generic, TypeVar

E = TypeVar("E")


class EventSource(Generic[E]):
    """Callbacks run on the bus thread; :meth:`iterate` hands events to any other thread."""

    def __init__(self) -> None:
        self._callbacks: list[Callable[[E], object]] = []
        self._queues: list[queue.SimpleQueue[E]] = []
        self._lock = threading.Lock()

    def subscribe(self, callback: Callable[[E], object]) -> Callable[[], None]:
        self._callbacks.append(callback)
        return lambda: self._callbacks.remove(callback) if callback in self._callbacks else None

    def emit(self, event: E) -> None:
        for callback in list(self._callbacks):
            callback(event)
        with self._lock:
            for waiting in self._queues:
                waiting.put(event)

    def iterate(self, timeout: float | None = None) -> Iterator[E]:
        """Events from the moment of this call (not of the first ``next``); the iterator ends
        after ``timeout`` seconds without one (None: never)."""
        waiting: queue.SimpleQueue[E] = queue.SimpleQueue()
        with self._lock:
            self._queues.append(waiting)
        return self._drain(waiting, timeout)

    def _drain(self, waiting: queue.SimpleQueue[E], timeout: float | None) -> Iterator[E]:
        try:
            while True:
                try:
                    yield waiting.get(timeout=timeout)
                except queue.Empty:
                    return
        finally:
            with self._lock:
                self._queues.remove(waiting)
