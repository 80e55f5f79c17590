"""The host side of one CAN bus: frames out, frames in by COB-ID, timers, one owning thread.

A python-can ``Notifier`` reads the bus (ours, or one that already reads it, such as a
python-canopen ``Network``'s: never a second notifier on one bus). Handlers and timers run on
this bus's own thread, one at a time, so drivers need no locks for their state. SDO replies
take a fast path: they are handed to the waiting caller straight from the reader thread.
An exception in a handler is logged with its traceback; the thread goes on.
"""

from __future__ import annotations

import heapq
import itertools
import logging
import queue
import threading
import time
from collections.abc import Callable
from concurrent.futures import Future
from typing import Any, TypeVar

import can

from blinkcan.host.sdo import SdoChannel
from blinkcan.protocol.cob import SYNC
from blinkcan.protocol.frame import Frame
from blinkcan.runtime.canbus import to_frame, to_message

log = logging.getLogger(__name__)
T = TypeVar("T")
Handler = Callable[[Frame, float], None]
_STOP = object()


class Timer:
    """A scheduled call; :meth:`cancel` stops it."""

    def __init__(self, due: float, period: float | None, callback: Callable[[], None]) -> None:
        self.due = due
        self.period = period
        self.callback = callback
        self.cancelled = False

    def cancel(self) -> None:
        self.cancelled = True


class _Listener(can.Listener):
    def __init__(self, owner: HostBus) -> None:
        self._owner = owner

    def on_message_received(self, msg: can.Message) -> None:
        self._owner._from_reader(msg)

    def on_error(self, exc: Exception) -> None:
        log.error("bus read failed: %s", exc)


class HostBus:
    """Runs the host side of ``bus``; pass ``network`` to share a python-canopen Network's bus."""

    def __init__(self, bus: can.BusABC | None = None, *, notifier: can.Notifier | None = None,
                 network: Any = None, clock: Callable[[], float] = time.monotonic) -> None:
        if network is not None:
            bus, notifier = network.bus, network.notifier
        if bus is None:
            raise TypeError("HostBus needs a python-can bus or a connected canopen Network")
        self.bus = bus
        self.clock = clock
        self._given_notifier = notifier
        self._notifier: can.Notifier | None = None
        self._listener = _Listener(self)
        self._handlers: dict[int, list[Handler]] = {}
        self._fast: dict[int, Handler] = {}
        self._extended: list[Handler] = []
        self._inbox: queue.SimpleQueue[Any] = queue.SimpleQueue()
        self._timers: list[tuple[float, int, Timer]] = []
        self._seq = itertools.count()
        self._thread: threading.Thread | None = None
        self._sdo: dict[int, SdoChannel] = {}

    # -- lifecycle --------------------------------------------------------------------------

    def start(self) -> HostBus:
        if self._thread is not None:
            return self
        self._thread = threading.Thread(target=self._run, name="blinkcan-host", daemon=True)
        self._thread.start()
        if self._given_notifier is not None:
            self._given_notifier.add_listener(self._listener)
        else:
            self._notifier = can.Notifier(self.bus, [self._listener], timeout=0.1)
        return self

    def stop(self) -> None:
        if self._thread is None:
            return
        if self._notifier is not None:
            self._notifier.stop()
            self._notifier = None
        elif self._given_notifier is not None:
            self._given_notifier.remove_listener(self._listener)
        self._inbox.put(_STOP)
        if threading.current_thread() is not self._thread:
            self._thread.join(timeout=5)
        self._thread = None
        while True:  # calls still queued will never run: fail them now
            try:
                item = self._inbox.get_nowait()
            except queue.Empty:
                break
            if isinstance(item, tuple) and isinstance(item[1], Future):
                item[1].set_exception(RuntimeError("the host bus was stopped"))

    def __enter__(self) -> HostBus:
        return self.start()

    def __exit__(self, *exc_info: object) -> None:
        self.stop()

    @property
    def on_own_thread(self) -> bool:
        return threading.current_thread() is self._thread

    # -- frames -------------------------------------------------------------------------------

    def send(self, frame: Frame) -> None:
        self.bus.send(to_message(frame))

    def subscribe(self, can_id: int, handler: Handler) -> Callable[[], None]:
        """Call ``handler(frame, now)`` on this bus's thread for every frame with ``can_id``;
        returns the function that unsubscribes."""
        handlers = self._handlers.setdefault(can_id, [])
        handlers.append(handler)
        return lambda: handlers.remove(handler) if handler in handlers else None

    def subscribe_extended(self, handler: Handler) -> Callable[[], None]:
        self._extended.append(handler)
        return lambda: self._extended.remove(handler) if handler in self._extended else None

    def subscribe_fast(self, can_id: int, handler: Handler) -> None:
        """Run ``handler`` on the reader thread: it must only hand the frame over."""
        self._fast[can_id] = handler

    def _from_reader(self, message: can.Message) -> None:
        frame = to_frame(message)
        if frame is None:
            return
        fast = self._fast.get(frame.can_id)
        if fast is not None and not frame.extended:
            fast(frame, self.clock())
        if frame.extended or frame.can_id in self._handlers:
            self._inbox.put((frame, self.clock()))

    def sdo(self, node_id: int, timeout: float = 0.5, retries: int = 1) -> SdoChannel:
        """The one SDO channel to ``node_id`` on this bus (shared by every driver)."""
        channel = self._sdo.get(node_id)
        if channel is None:
            channel = self._sdo[node_id] = SdoChannel(self, node_id, timeout, retries)
        return channel

    def produce_sync(self, period: float) -> Timer:
        """Send SYNC (COB-ID 80h, no data) every ``period`` s, for devices in synchronous mode
        (PKP rev 1.5 §10); ``cancel()`` the returned timer to stop."""
        sync = Frame(SYNC, b"")
        return self.call_every(period, lambda: self.send(sync))

    # -- timers and calls on the bus thread ----------------------------------------------------

    def call_later(self, delay: float, callback: Callable[[], None]) -> Timer:
        return self._schedule(Timer(self.clock() + delay, None, callback))

    def call_every(self, period: float, callback: Callable[[], None], first: float = 0.0) -> Timer:
        if period <= 0:
            raise ValueError(f"period must be > 0 seconds, got {period}")
        return self._schedule(Timer(self.clock() + first, period, callback))

    def _schedule(self, timer: Timer) -> Timer:
        self._inbox.put(timer)
        return timer

    def run(self, action: Callable[[], T], timeout: float = 5.0) -> T:
        """Run ``action`` on this bus's thread and return its result."""
        if self._thread is None or self.on_own_thread:
            return action()
        future: Future[T] = Future()
        self._inbox.put((action, future))
        return future.result(timeout)

    def _run(self) -> None:
        while True:
            now = self.clock()
            wait = self._timers[0][0] - now if self._timers else 0.5
            item: Any = None
            if wait > 0:
                try:
                    item = self._inbox.get(timeout=min(wait, 0.5))
                except queue.Empty:
                    item = None
            while True:
                if item is _STOP:
                    return
                if item is not None:
                    self._handle(item)
                try:
                    item = self._inbox.get_nowait()
                except queue.Empty:
                    break
            self._run_timers()

    def _handle(self, item: Any) -> None:
        if isinstance(item, Timer):
            heapq.heappush(self._timers, (item.due, next(self._seq), item))
            return
        first, second = item
        if isinstance(first, Frame):
            handlers = self._extended if first.extended else self._handlers.get(first.can_id, ())
            for handler in list(handlers):
                self._guard(handler, first, second)
            return
        action, future = first, second
        try:
            future.set_result(action())
        except BaseException as error:
            future.set_exception(error)

    def _run_timers(self) -> None:
        timers = self._timers
        while timers and timers[0][0] <= self.clock():
            due, _, timer = heapq.heappop(timers)
            if timer.cancelled:
                continue
            if timer.period is not None:
                timer.due = max(due + timer.period, self.clock())
                heapq.heappush(timers, (timer.due, next(self._seq), timer))
            self._guard(timer.callback)

    @staticmethod
    def _guard(callback: Callable[..., object], *args: object) -> None:
        try:
            callback(*args)
        except Exception:
            log.exception("a blinkcan handler raised; the host bus goes on")
