"""The asyncio face of the drivers: the same names, as coroutines and async iterators.

``AsyncKeypad(bus, ...)`` takes the arguments of :class:`Keypad`. Blocking calls (SDO), the
driver's own opening and its properties (``await keypad.generation``)
run in a worker thread: the event loop never blocks. Events reach the loop through
``call_soon_threadsafe``; iterators end when the driver closes. Callbacks given
to ``on_key`` and the like still run on the bus thread, as with the blocking drivers.

In simulated time (a ``blinkcan.testing.Rig``'s bus) nothing runs in a worker thread: a call,
a property, the opening and an iterator's wait run the simulation in the thread that awaits
them (the event loop's, which is the rig's), one after the other, as the blocking driver's
calls do. The simulation has one thread (``runtime.scheduler``): calls in workers ran it from
several threads at once, and concurrent calls on a rig failed ("SDO transfers block", missing
replies) or put their frames on the wire in an order that changed from run to run. A virtual
wait takes no wall time to speak of (at most ``LONGEST_VIRTUAL_WAIT`` virtual seconds), so
the loop is not held for long. The driver opens at once, when it is made (as outside a loop).

A cancelled call (``asyncio.wait_for``'s timeout) cancels that call only: the driver and its
other calls go on (in simulated time a call runs whole, or not at all when it was cancelled
before it started). What the worker thread was sending still completes (as an SDO timeout's
write may still have been applied); only the caller stops waiting for it. The driver's picture
follows what the device confirms, whoever waits: a cancelled ``off(4)`` the Keybox acknowledges
later makes ``actual[4]`` "off" then, never before; one whose acknowledge never comes is read
back (``Keybox``). A failure nobody awaits any more is logged, never left unretrieved.
"""

from __future__ import annotations

import asyncio
import functools
import logging
import threading
from collections.abc import AsyncIterator, Callable
from typing import Any, Generic, TypeVar

from blinkcan.host.device import Device, runs_in_simulated_time
from blinkcan.host.events import EventSource, check_event_timeout
from blinkcan.host.keybox import FaultEvent, Keybox
from blinkcan.host.keypad import KeyEvent, Keypad
from blinkcan.host.scan import Found, scan

E = TypeVar("E")
D = TypeVar("D", bound=Device)
T = TypeVar("T")

log = logging.getLogger(__name__)


def _in_running_loop() -> bool:
    try:
        asyncio.get_running_loop()
    except RuntimeError:
        return False
    return True


async def _in_worker(work: Callable[[], T], what: str) -> T:
    """``work()`` in a worker thread. Cancelling the caller cancels its wait only: the work
    runs to its end, and a failure nobody awaits any more is logged (else it would vanish)."""
    running = asyncio.ensure_future(asyncio.to_thread(work))
    try:
        return await asyncio.shield(running)
    except asyncio.CancelledError:
        running.add_done_callback(functools.partial(_report_unawaited, what))
        raise


def _call_text(name: str, args: tuple[Any, ...], kwargs: dict[str, Any]) -> str:
    """``off(4)``: a call as its caller wrote it, for the log."""
    shown = [repr(arg) for arg in args] + [f"{key}={value!r}" for key, value in kwargs.items()]
    return f"{name}({', '.join(shown)})"


def _report_unawaited(what: str, done: asyncio.Future[Any]) -> None:
    if not done.cancelled() and done.exception() is not None:
        log.warning("%s, cancelled by its caller, failed afterwards: %s", what, done.exception())


def _iterate(opened: AsyncDriver[Any], source: Callable[[Any], EventSource[E]],
             timeout: float | None) -> AsyncIterator[E]:
    """Events from the moment of this call on (from the moment the driver is open, if it is
    still opening). A subscription whose event loop has closed removes itself."""
    check_event_timeout(timeout)
    loop = asyncio.get_running_loop()
    loop_thread = threading.get_ident()
    waiting: asyncio.Queue[E] = asyncio.Queue()
    removers: list[Callable[[], None]] = []
    arrivals = _Arrivals()

    def deliver(event: E) -> None:
        arrivals.count += 1
        if threading.get_ident() == loop_thread and not loop.is_closed():
            waiting.put_nowait(event)  # the simulation, run by the loop's own thread
            return
        try:
            loop.call_soon_threadsafe(waiting.put_nowait, event)
        except RuntimeError:  # the loop is closed: nobody will read this iterator
            for remove in removers:
                remove()

    def subscribe(device: Any) -> None:
        removers.append(source(device).subscribe(deliver))

    if opened._device is not None:
        subscribe(opened._device)
    return _drain(opened, subscribe, removers, waiting, arrivals, source, timeout)


class _Arrivals:
    """How many events reached an async iterator (counted on the bus thread): a simulated
    wait for the next one runs until the count moves."""

    __slots__ = ("count",)

    def __init__(self) -> None:
        self.count = 0


def _next_simulated(events: EventSource[E], waiting: asyncio.Queue[E],
                    arrivals: _Arrivals, timeout: float | None) -> bool:
    """Simulated time: run the simulation, in this thread (the loop's: the simulation's one
    thread), until an event arrives, the driver closes or ``timeout`` virtual seconds pass;
    nothing else would move the clock, so waiting for an event in real time would wait for
    ever. True when an event is waiting."""
    if waiting.empty():
        seen = arrivals.count
        events.run_until(lambda: arrivals.count != seen or events.closed, timeout)
    return not waiting.empty()  # the arrivals were put in the queue by this thread


async def _drain(opened: AsyncDriver[Any], subscribe: Callable[[Any], None],
                 removers: list[Callable[[], None]], waiting: asyncio.Queue[E],
                 arrivals: _Arrivals, source: Callable[[Any], EventSource[E]],
                 timeout: float | None) -> AsyncIterator[E]:
    try:
        if not removers:
            await opened.open()
            subscribe(opened._device)
        events = source(opened._device)
        while True:
            if events.closed and waiting.empty():
                return  # the driver was closed
            if events.simulated:
                if not _next_simulated(events, waiting, arrivals, timeout):
                    return  # timeout virtual seconds without one, or the driver closed
                yield waiting.get_nowait()
                continue
            try:
                yield await asyncio.wait_for(waiting.get(), 0.1 if timeout is None
                                             else min(timeout, 0.1))
            except asyncio.TimeoutError:
                if timeout is not None:
                    timeout -= 0.1
                    if timeout <= 0:
                        return
    finally:
        for remove in removers:
            remove()


class AsyncDriver(Generic[D]):
    """Wraps a blocking driver: its methods and properties become coroutines, run in a worker
    thread, so the event loop never blocks. Built inside a running loop, the driver opens in
    a worker thread too (``await x.open()`` or the first awaited call waits for it). In
    simulated time they run in the awaiting thread instead (see the module docstring).

    The base of every asyncio face: a model's face names its blocking driver in ``_driver``
    and turns each of its event sources into an async iterator with :meth:`stream`."""

    _driver: Callable[..., D]

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        make = functools.partial(self._driver, *args, **kwargs)
        self._device: D | None = None
        self._opening: asyncio.Future[D] | None = None
        #: on a simulated bus every call runs in the awaiting thread: the simulation's one
        self._simulated = runs_in_simulated_time(args[0] if args else kwargs.get("bus"))
        if self._simulated or not _in_running_loop():
            self._device = make()
        else:
            self._opening = asyncio.ensure_future(asyncio.to_thread(make))

    async def open(self) -> Any:
        if self._device is None:
            assert self._opening is not None
            # shared by every call: a caller's cancellation (its timeout) cancels that call's
            # wait only, never the opening the driver's other calls wait for
            self._device = await asyncio.shield(self._opening)
        return self

    @property
    def device(self) -> D:
        if self._device is None:
            raise RuntimeError("the driver is still opening: await .open() first")
        return self._device

    def __getattr__(self, name: str) -> Any:
        if name.startswith("_"):
            raise AttributeError(name)
        kind = getattr(type(self).__dict__.get("_driver"), name, None)
        if isinstance(kind, property):  # a property may do I/O (an SDO): await it

            async def read() -> Any:
                await self.open()
                return await self._run(functools.partial(getattr, self._device, name), name)

            return read()
        if callable(kind) and not name.startswith("on_"):

            @functools.wraps(kind)
            async def call(*args: Any, **kwargs: Any) -> Any:
                await self.open()
                return await self._run(
                    functools.partial(getattr(self._device, name), *args, **kwargs),
                    _call_text(name, args, kwargs))

            return call
        return getattr(self.device, name)  # callbacks register at once; values as they are

    async def _run(self, work: Callable[[], T], what: str) -> T:
        """``work()``: here in simulated time (the simulation's thread), else in a worker."""
        if self._simulated:
            return work()
        return await _in_worker(work, what)

    def stream(self, source: Callable[[D], EventSource[E]], timeout: float | None = None
               ) -> AsyncIterator[E]:
        """The events of the driver's source ``source(driver)`` (its ``keys``, ``health``...)
        from this call on, as an async iterator; it ends when the driver closes, or after
        ``timeout`` seconds without an event."""
        return _iterate(self, source, timeout)

    def health_events(self, timeout: float | None = None) -> AsyncIterator[Any]:
        return self.stream(lambda device: device.health, timeout)

    async def __aenter__(self) -> Any:
        return await self.open()

    async def __aexit__(self, *exc_info: object) -> None:
        await self.open()
        await self._run(self.device.close, "close()")


class AsyncKeypad(AsyncDriver[Keypad]):
    _driver = Keypad

    def events(self, timeout: float | None = None) -> AsyncIterator[KeyEvent]:
        return self.stream(lambda device: device.keys, timeout)


class AsyncKeybox(AsyncDriver[Keybox]):
    _driver = Keybox

    def fault_events(self, timeout: float | None = None) -> AsyncIterator[FaultEvent]:
        return self.stream(lambda device: device.faults, timeout)


async def async_scan(*args: Any, **kwargs: Any) -> list[Found]:
    """:func:`scan` in a worker thread (in the awaiting thread in simulated time)."""
    if runs_in_simulated_time(args[0] if args else kwargs.get("bus")):
        return scan(*args, **kwargs)
    return await asyncio.to_thread(scan, *args, **kwargs)


__all__ = ["AsyncDriver", "AsyncKeybox", "AsyncKeypad", "async_scan"]
