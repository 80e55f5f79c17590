"""The host side of one CAN bus: frames out, frames in by COB-ID, timers, one owning loop.

Every driver and ``scan`` on one python-can bus share one ``HostBus`` (:meth:`HostBus.attach`):
it is found again through the notifier that reads the bus (python-can's
``Notifier.find_instances``), so any number of drivers work on one bus, and a notifier that
already reads it (a python-canopen ``Network``'s, the application's) is joined, never doubled.

The bus is a transport port (``runtime.port``: python-can's or the simulated one, never asked
which). Handlers and timers run on the port's scheduler (``runtime.scheduler``), one at a
time, so drivers need no locks for their state: a loop of its own on real buses (its thread,
or the reader's while it holds the loop to run a frame's handlers), the simulation itself in
virtual time (``blinkcan.testing.Rig``). SDO replies take a fast path:
they are handed to the waiting caller straight from the port's reader. An exception in a
handler is logged with its traceback and the loop goes on; in simulated time it is raised
again from the call that ran the simulation (``Scheduler.guarded``), so a test sees it.

A python-can bus is read the way every blinkcan reader reads (``runtime.canport``): a frame
it cannot decode is counted and dropped, a failing bus (unplugged adapter) is reported once and
read with a back-off instead of a busy loop, and a shut-down bus stops the reader and fails
waiting SDO calls at once; frames this program sent are never taken for received ones.
"""

from __future__ import annotations

import logging
import operator
import threading
import time
from collections.abc import Callable, Hashable
from typing import Any, TypeVar

import can

from blinkcan.host.sdo import SdoChannel, SdoClient
from blinkcan.protocol.cob import SYNC
from blinkcan.protocol.frame import Frame
from blinkcan.runtime.canbus import ReadStats
from blinkcan.runtime.port import Port, port_for, take_port
from blinkcan.runtime.scheduler import Scheduler, Signal, Timer

log = logging.getLogger(__name__)
T = TypeVar("T")
Handler = Callable[[Frame, float], None]

__all__ = ["Handler", "HostBus", "Timer"]


class HostBus:
    """Runs the host side of ``bus`` (a python-can bus, or a :class:`Port`); pass ``network``
    to share a python-canopen Network's bus.

    Drivers get theirs with :meth:`attach` (shared per bus, stopped when the last driver
    closes); a ``HostBus`` you make and start yourself stays yours to stop. A port given
    stays the caller's: :meth:`stop` leaves its scheduler running.
    """

    #: drivers attach and release one at a time, process-wide (rare, and never two hosts
    #: for one bus: two SDO channels to one node would take each other's replies)
    _attaching = threading.RLock()
    #: ``send(frame)``: put a frame on the bus (the port's own send, no call in between:
    #: every SDO request goes this way)
    send: Callable[[Frame], None]

    def __init__(self, bus: can.BusABC | Port | None = None, *,
                 notifier: can.Notifier | None = None, network: Any = None,
                 clock: Callable[[], float] = time.monotonic) -> None:
        if network is not None:
            bus, notifier = network.bus, network.notifier
        if bus is None:
            raise TypeError("HostBus needs a python-can bus, a port or a connected canopen "
                            "Network")
        taken = take_port(bus, notifier=notifier, clock=clock, name="blinkcan-host")
        #: the python-can bus given (None when made on a port)
        self.bus: can.BusABC | None = taken.bus
        self._owns_port = taken.owned
        self.port: Port = taken.port
        self.send = self.port.send
        self.scheduler: Scheduler = self.port.scheduler
        self.simulated = self.scheduler.simulated
        #: the loop's handlers of a frame, as the port's reader hands them one (bound once)
        self._deliver_dispatch = self.scheduler.deliverer(self._dispatch)
        self._handlers: dict[int, list[Handler]] = {}
        self._fast: dict[int, Handler] = {}
        self._extended: list[Handler] = []
        self._sdo: dict[int, SdoChannel] = {}
        self._sdo_lock = threading.Lock()
        self._detach: Callable[[], None] | None = None
        self._started = False
        self._users = 0
        self._auto = False
        #: what reading the bus met: frames it could not decode, failures, a shut-down
        self.reading: ReadStats = self.port.reading

    # -- sharing ----------------------------------------------------------------------------

    @classmethod
    def attach(cls, bus: HostBus | can.BusABC | Port) -> HostBus:
        """The running ``HostBus`` of ``bus``, shared by every driver on it; call
        :meth:`release` when done."""
        with cls._attaching:
            if isinstance(bus, HostBus):
                bus._users += 1
                return bus.start()
            port = port_for(bus, name="blinkcan-host") if isinstance(bus, can.BusABC) else bus
            found = cls._find(port)
            if found is not None:
                found._users += 1
                return found
            host = cls(port)
            if isinstance(bus, can.BusABC):
                host.bus, host._owns_port = bus, True
            host._auto = True
            host._users = 1
            return host.start()

    @staticmethod
    def _find(port: Port) -> HostBus | None:
        """The started ``HostBus`` that a port of the same bus feeds, if any."""
        for handler in port.listeners():
            owner = getattr(handler, "__self__", None)
            if isinstance(owner, HostBus) and owner._started:
                return owner
        return None

    def release(self) -> None:
        """One driver fewer; the last one out stops a ``HostBus`` that :meth:`attach` made
        (fully, before another driver can attach: no one joins a reader that is stopping)."""
        with self._attaching:
            self._users = max(0, self._users - 1)
            if self._users == 0 and self._auto:
                self.stop()

    # -- lifecycle --------------------------------------------------------------------------

    def start(self) -> HostBus:
        if self._started:
            return self
        self._started = True
        self.scheduler.start()
        self._detach = self.port.listen(self._on_frame, self._bus_closed)
        return self

    def stop(self) -> None:
        if not self._started:
            return
        self._started = False
        if self._detach is not None:
            self._detach()
            self._detach = None
        if self._owns_port:
            self.scheduler.stop()

    def __enter__(self) -> HostBus:
        return self.start()

    def __exit__(self, *exc_info: object) -> None:
        self.stop()

    # -- the loop -----------------------------------------------------------------------------

    @property
    def on_own_thread(self) -> bool:
        return self.scheduler.in_loop

    #: True inside a handler or timer, where nothing may block (the scheduler's ``in_loop``,
    #: read by a C-level getter: every SDO request asks)
    in_handler = property(operator.attrgetter("scheduler.in_loop"),
                          doc="True inside a handler or timer, where nothing may block.")

    @property
    def closed(self) -> bool:
        """The bus was shut down: nothing is read from it any more."""
        return self.reading.closed

    @property
    def error(self) -> Exception | None:
        """The last read error while the bus fails (None while it reads)."""
        return self.reading.error

    def clock(self) -> float:
        return self.scheduler.clock()

    def call_later(self, delay: float, callback: Callable[[], object]) -> Timer:
        return self.scheduler.call_later(delay, callback)

    def call_every(self, period: float, callback: Callable[[], object], first: float = 0.0
                   ) -> Timer:
        return self.scheduler.call_every(period, callback, first)

    def run(self, action: Callable[[], T], timeout: float = 5.0) -> T:
        """Run ``action`` on this bus's loop and return its result."""
        return self.scheduler.run(action, timeout)

    def spawn(self, action: Callable[[], object], key: Hashable | None = None) -> None:
        """Blocking work (SDO) from a handler: run outside the loop, on a bounded pool; work
        with the same ``key`` still pending is not queued twice."""
        self.scheduler.spawn(action, key)

    def signal(self) -> Signal:
        return self.scheduler.signal()

    def wait(self, signal: Signal, timeout: float) -> bool:
        """Wait for ``signal`` (False after ``timeout``); returns at once when the bus is
        gone."""
        if self.reading.closed:
            return signal.is_set()
        return self.scheduler.wait(signal, timeout)

    def sleep(self, seconds: float) -> None:
        self.scheduler.sleep(seconds)

    # -- frames -------------------------------------------------------------------------------

    def subscribe(self, can_id: int, handler: Handler) -> Callable[[], None]:
        """Call ``handler(frame, now)`` on this bus's loop for every frame with ``can_id``;
        returns the function that unsubscribes."""
        handlers = self._handlers.setdefault(can_id, [])
        handlers.append(handler)
        return lambda: handlers.remove(handler) if handler in handlers else None

    def subscribe_extended(self, handler: Handler) -> Callable[[], None]:
        self._extended.append(handler)
        return lambda: self._extended.remove(handler) if handler in self._extended else None

    def subscribe_fast(self, can_id: int, handler: Handler) -> Callable[[], None]:
        """Run ``handler`` on the reader thread: it must only hand the frame over. Returns
        the function that puts back the handler it replaced (if any)."""
        previous = self._fast.get(can_id)
        self._fast[can_id] = handler

        def restore() -> None:
            if previous is None:
                self._fast.pop(can_id, None)
            else:
                self._fast[can_id] = previous

        return restore

    def _on_frame(self, frame: Frame, now: float) -> None:
        """A frame from the port, in its receiving context: an SDO reply straight to its
        waiting caller, the rest to the handlers on this bus's loop."""
        extended = frame.extended
        if not extended:
            fast = self._fast.get(frame.can_id)
            if fast is not None:
                fast(frame, now)
        if extended or frame.can_id in self._handlers:
            self._deliver_dispatch(frame, now)

    def _dispatch(self, frame: Frame, now: float) -> None:
        handlers = self._extended if frame.extended else self._handlers.get(frame.can_id, ())
        for handler in list(handlers):
            self.scheduler.guarded(handler, frame, now)

    def _bus_closed(self) -> None:
        """On the reader thread, once the bus was shut down: waiting SDO calls return now
        (and fail: the bus is closed)."""
        for channel in list(self._sdo.values()):
            channel.wake()

    # -- services -----------------------------------------------------------------------------

    def sdo(self, node_id: int, timeout: float = 0.5, retries: int = 1) -> SdoClient:
        """A client of the one SDO channel to ``node_id`` on this bus (shared by every driver,
        so requests to a node never overlap), with its own ``timeout`` and ``retries``."""
        with self._sdo_lock:  # drivers opened in two threads at once share one channel too
            channel = self._sdo.get(node_id)
            if channel is None:
                channel = self._sdo[node_id] = SdoChannel(self, node_id)
        return SdoClient(channel, timeout, retries)

    def produce_sync(self, period: float) -> Timer:
        """Send SYNC (COB-ID 80h, no data) every ``period`` s, for devices in synchronous mode
        (PKP rev 1.5 §10); ``cancel()`` the returned timer to stop."""
        sync = Frame(SYNC, b"")
        return self.call_every(period, lambda: self.send(sync))
