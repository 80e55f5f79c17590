"""A CAN bus in simulated time: frames delivered in order, at the virtual time they were sent.

:class:`SimulatedNetwork` is the wire: every frame sent is recorded with its time and handed to
every other endpoint through the :class:`SimulatedScheduler`, never to its sender (a real
controller does not receive its own frames). :class:`SimulatedBus` is one endpoint with
python-can's ``BusABC`` interface, so drivers and application code take it like any bus; the
Emulator and the host drivers attach frame handlers directly and skip ``can.Message``.

Fault injection lives on the wire: rules that drop or delay frames, and a bus that goes away.

Other libraries on a :class:`SimulatedBus` (python-canopen's ``Network``, cantools' ``Tester``, a
plain ``can.Notifier``) stay in simulated time:

- **A ``can.Notifier`` put on the bus is driven by the simulation, not by its thread.** python-can
  asks a bus for ``fileno()`` while it registers a notifier; the bus adopts the notifier there
  (in the caller's thread, at a known virtual time) and from then on hands every frame it
  receives to the notifier's listeners itself, in simulation order, at the frame's virtual
  time (``msg.timestamp``). The notifier's own thread still starts and calls ``recv()``; a call
  from an adopted notifier's thread is parked (it reads nothing and runs nothing) until that
  notifier is stopped or the bus shuts down, so no second thread ever touches the simulation.
  Why this and not a python-can interface of our own: every library takes a bus *object*
  (``canopen.Network(bus)``, ``Tester(..., bus)``, ``Notifier(bus, ...)``), so the rig's bus
  works as written; an interface opened by name would need a process-wide name-to-rig table
  and would still leave the notifier's thread reading the simulation from another thread.
  A listener runs as on a real bus: one frame at a time, and while it runs (a blocking call in
  a listener) the notifier hears nothing more, as its real thread would not; frames that
  arrive meanwhile are handed over when it returns. A notifier hears the frames that reach the
  bus after it was made; ``shutdown()`` stops the notifiers still reading the bus.
  A notifier with an asyncio loop is refused (its listeners would run outside virtual time).
- **``send_periodic`` runs on the simulation's clock** (python-canopen's SYNC producer and RPDO
  ``start()``, cantools' periodic messages), not on a thread.
- The blocking waits of those libraries (an SDO reply, a heartbeat) run the simulation in
  virtual time: :mod:`blinkcan.runtime.virtual_waits`, installed while the bus has adopted a
  notifier and undone when it shuts down.
"""

from __future__ import annotations

import collections
import logging
import threading
from collections.abc import Callable, Sequence
from typing import Any

import can
from can.broadcastmanager import (
    LimitedDurationCyclicSendTaskABC,
    ModifiableCyclicTaskABC,
    RestartableCyclicTaskABC,
)

from blinkcan.protocol.cob import check_time
from blinkcan.protocol.frame import Frame
from blinkcan.runtime.canbus import to_frame, to_message
from blinkcan.runtime.scheduler import SimulatedScheduler
from blinkcan.runtime.virtual_waits import (
    RECV_FOREVER,
    check_virtual_timeout,
    install_virtual_waits,
)
from blinkcan.runtime.wire_log import TimedFrame, WireLog

__all__ = ["FrameHandler", "Receiver", "SimulatedBus", "SimulatedCyclicTask",
           "SimulatedNetwork", "TimedFrame", "WireLog"]

log = logging.getLogger(__name__)
FrameHandler = Callable[[Frame, float], None]
#: an endpoint of the wire: takes every frame the others send, at the time it was sent (the
#: scheduler's ``now``)
Receiver = Callable[[Frame], None]
#: frames an endpoint keeps for recv() (the oldest go first)
_KEPT = 100_000
#: wall seconds between two looks of a parked notifier thread at whether its notifier stopped
_PARKED_POLL = 0.005
#: a wire rule: for a frame, None (unchanged), "drop", or extra delay in seconds
Rule = Callable[[Frame], "str | float | None"]


class SimulatedNetwork:
    """The shared wire of one simulation.

    A frame sent is recorded in :attr:`frames` (a :class:`WireLog`) and handed to every other
    endpoint, each endpoint's turn an event of its own, in order, at the time it was sent: no
    copy, record object, closure or timer per frame.
    """

    def __init__(self, scheduler: SimulatedScheduler, latency: float = 0.0) -> None:
        check_time("latency", latency, 0)
        self.scheduler = scheduler
        self.latency = latency
        self._frames = WireLog()
        self.up = True
        #: the endpoints' receivers, a tuple: delivery reads it for every frame, connect and
        #: detach (rare) replace it
        self._receivers: tuple[Receiver, ...] = ()
        #: the receiver made for each handler :meth:`attach` took
        self._attached: dict[FrameHandler, Receiver] = {}
        self._rules: list[Rule] = []
        #: frames held back by the latency or a delay rule, not yet arrived
        self._late = 0

    @property
    def frames(self) -> WireLog:
        """Every frame that went on the wire, with its time (reads as a list of TimedFrame;
        one log for the network's life: its senders write to it)."""
        return self._frames

    @property
    def in_flight(self) -> int:
        """Frames sent and not yet handed over: one per endpoint still to receive it, and one
        per frame the latency or a delay rule holds back."""
        receivers = self._receivers
        waiting = sum(1 for callback, _ in self.scheduler.deferred()
                      if any(callback is receiver for receiver in receivers))
        return self._late + waiting

    def connect(self, receiver: Receiver) -> Callable[[], None]:
        """Hand every frame sent by others to ``receiver(frame)``, at the time it was sent
        (``scheduler.now``); the receiver checks :attr:`up` first (a frame in flight when the
        bus went down is not delivered). Returns the detach."""
        self._receivers += (receiver,)

        def detach() -> None:
            self._receivers = tuple(known for known in self._receivers if known is not receiver)

        return detach

    def attach(self, handler: FrameHandler) -> Callable[[], None]:
        """Deliver every frame sent by others to ``handler(frame, now)``; returns the detach."""

        scheduler = self.scheduler

        def receive(frame: Frame) -> None:
            if self.up:
                handler(frame, scheduler.now)

        self._attached[handler] = receive
        detach = self.connect(receive)

        def detach_handler() -> None:
            detach()
            if self._attached.get(handler) is receive:
                del self._attached[handler]

        return detach_handler

    def add_rule(self, rule: Rule) -> Callable[[], None]:
        """A rule that may drop or delay frames; returns the function that removes it."""
        self._rules.append(rule)
        return lambda: self._rules.remove(rule) if rule in self._rules else None

    def transmit(self, frame: Frame, sender: Receiver | FrameHandler | None) -> None:
        """Put ``frame`` on the wire as the endpoint ``sender`` (its receiver, or the handler
        it attached; None: no endpoint's); raises ``can.CanOperationError`` when the bus is
        gone."""
        self.sender(sender)(frame)

    def sender(self, endpoint: Receiver | FrameHandler | None) -> Callable[[Frame], None]:
        """``transmit(frame, endpoint)`` as a function of the frame: the send of that
        endpoint, made once (every frame of a simulation comes this way)."""
        mine: object = self._attached.get(endpoint, endpoint)  # type: ignore[arg-type]
        scheduler = self.scheduler
        defer = scheduler.deferrer()
        record_time, record_frame = self._frames.writers()

        def send(frame: Frame) -> None:
            if not self.up:
                raise can.CanOperationError("the simulated bus is down")
            if self._rules or self.latency:
                self._transmit_late(frame, mine)
                return
            # _deliver, inlined
            record_time(scheduler.now)
            record_frame(frame)
            for receiver in self._receivers:  # a tuple: an endpoint attached meanwhile waits
                if receiver is not mine:
                    defer((receiver, frame))

        return send

    def _transmit_late(self, frame: Frame, sender: object) -> None:
        """``frame`` through the rules, then on the wire after the latency and delays."""
        delay = self.latency
        for rule in self._rules:
            verdict = rule(frame)
            if verdict == "drop":
                return
            if isinstance(verdict, (int, float)):
                delay += float(verdict)
        if delay:
            self._late += 1
            self.scheduler.call_later(delay, lambda: self._arrive(frame, sender))
        elif self.up:
            self._deliver(frame, sender)

    def _arrive(self, frame: Frame, sender: object) -> None:
        self._late -= 1
        if self.up:
            self._deliver(frame, sender)

    def _deliver(self, frame: Frame, sender: object) -> None:
        """Record ``frame`` and hand it to every other endpoint after what runs now (each
        endpoint's turn is an event of its own, in order, at this same time)."""
        scheduler = self.scheduler
        self._frames.record(scheduler.now, frame)
        for receiver in self._receivers:
            if receiver is not sender:
                scheduler.defer(receiver, frame)


class SimulatedBus(can.BusABC):
    """One endpoint of a :class:`SimulatedNetwork`, with python-can's bus interface.

    ``recv(timeout)`` runs the simulation until a frame arrives or ``timeout`` virtual seconds
    passed (``recv()`` with no timeout: at most :data:`RECV_FOREVER`). A ``can.Notifier`` on it
    is driven by the simulation (see the module docstring), and ``send_periodic`` runs on the
    virtual clock.
    """

    send_frame: Callable[[Frame], None]

    def __init__(self, network: SimulatedNetwork, channel: str = "simulated",
                 **kwargs: Any) -> None:
        super().__init__(channel=channel, **kwargs)
        self.network = network
        self.scheduler = network.scheduler
        self.channel_info = f"simulated bus {channel}"
        #: frames received and not yet read by recv(), and their times (two columns: no
        #: object per frame, see runtime.wire_log)
        self._received: collections.deque[Frame] = collections.deque(maxlen=_KEPT)
        self._received_times: collections.deque[float] = collections.deque(maxlen=_KEPT)
        self._listeners: list[FrameHandler] = []
        #: this endpoint on the wire (one bound method, known by identity)
        self._receiver: Receiver = self._receive
        self._detach = network.connect(self._receiver)
        #: put a frame on the wire as this endpoint's (not heard back here)
        self.send_frame = network.sender(self._receiver)
        #: the can.Notifiers this bus delivers to (stopped ones are dropped on the next frame)
        self._notifiers: list[can.Notifier] = []
        #: every notifier adopted (their threads are recognised until they stop)
        self._adopted: list[can.Notifier] = []
        #: messages that came while a notifier listener was running, handed over after it
        self._held: collections.deque[can.Message] = collections.deque()
        self._delivering = False
        self._closed = threading.Event()
        self._undo_waits: list[Callable[[], None]] = []

    def add_frame_listener(self, handler: FrameHandler) -> Callable[[], None]:
        """Call ``handler(frame, now)`` for every frame this endpoint receives."""
        self._listeners.append(handler)
        return lambda: self._listeners.remove(handler) if handler in self._listeners else None

    def frame_listeners(self) -> list[FrameHandler]:
        """The handlers :meth:`add_frame_listener` attached."""
        return list(self._listeners)

    def _receive(self, frame: Frame) -> None:
        """A frame another endpoint sent reaches this one, at the time it was sent."""
        if not self.network.up:
            return  # in flight when the bus went down
        now = self.scheduler.now
        if self._notifiers:
            self._notify(frame, now)
        else:
            self._received.append(frame)
            self._received_times.append(now)
        for listener in self._listeners:
            listener(frame, now)

    # -- can.Notifier, driven by the simulation ---------------------------------------------

    def fileno(self) -> int:
        """python-can asks this while it registers a ``can.Notifier`` on the bus: the bus
        adopts it here, then answers as a bus without a file descriptor does."""
        self._adopt_notifiers()
        raise NotImplementedError("a simulated bus has no file descriptor")

    def _adopt_notifiers(self) -> None:
        for notifier in can.Notifier.find_instances(self):
            if notifier.stopped or any(notifier is known for known in self._adopted):
                continue
            if getattr(notifier, "_loop", None) is not None:
                notifier.stop()
                raise ValueError("a can.Notifier with an asyncio loop cannot run in simulated "
                                 "time: make it without loop=")
            self._notifiers.append(notifier)
            self._adopted.append(notifier)
            # the libraries that made it are imported now: their waits go virtual
            self._undo_waits.append(install_virtual_waits())

    def _notify(self, frame: Frame, now: float) -> None:
        """Hand ``frame`` to the adopted notifiers' listeners, as their thread would."""
        active = [notifier for notifier in self._notifiers if not notifier.stopped]
        if len(active) != len(self._notifiers):
            self._notifiers = active
        message = to_message(frame, now)
        if not active or not self._matches_filters(message):
            if not active:
                self._received.append(frame)
                self._received_times.append(now)
            return
        self._held.append(message)
        if self._delivering:
            return  # a listener is running: its notifier's thread would be busy with it
        self._delivering = True
        try:
            while self._held:
                held = self._held.popleft()
                for notifier in self._notifiers:
                    if notifier.stopped:
                        continue
                    for listener in list(notifier.listeners):
                        self.scheduler.guarded(listener, held, what="a can.Notifier listener")
        finally:
            self._delivering = False

    @property
    def delivering(self) -> bool:
        """True while a notifier listener runs (its real thread would be busy: nothing more
        reaches that notifier until the listener returns)."""
        return self._delivering

    def _parked(self) -> bool:
        """Park a recv() from an adopted notifier's thread until that notifier stops (or the
        bus shuts down); True when it was one. python-can names the thread after the bus and
        lists it in the notifier's readers just after starting it: either tells."""
        me = threading.current_thread()
        if not me.name.endswith(f'for bus "{self.channel_info}"') and not any(
                me in getattr(notifier, "_readers", ()) for notifier in self._adopted):
            return False
        while not self._closed.is_set():
            mine = [notifier for notifier in self._adopted
                    if me in getattr(notifier, "_readers", ())]
            if all(notifier.stopped for notifier in mine or self._adopted):
                break
            self._closed.wait(_PARKED_POLL)
        return True

    # -- sending and receiving --------------------------------------------------------------

    def send(self, msg: can.Message, timeout: float | None = None) -> None:
        frame = to_frame(msg)
        if frame is None:
            raise can.CanOperationError("the simulated bus carries data frames of up to 8 bytes")
        self.send_frame(frame)

    def recv(self, timeout: float | None = None) -> can.Message | None:
        """The next frame received (filters applied), running the simulation until it comes
        or ``timeout`` virtual seconds passed (None or infinity: at most :data:`RECV_FOREVER`; a
        finite timeout up to :data:`LONGEST_VIRTUAL_WAIT`, else ValueError; 0: a frame
        due at this very instant, the clock stays). Called by
        the thread of a notifier the bus adopted: parked until that notifier stops, None."""
        if self._adopted and self._parked():
            return None
        received = self._received
        scheduler = self.scheduler
        if timeout is not None:  # NaN is refused; +inf waits as None does
            check_time("timeout", timeout, infinite=True)
        wait = RECV_FOREVER if timeout is None or timeout == float("inf") else \
            max(0.0, check_virtual_timeout(timeout))
        end = scheduler.clock() + wait
        times = self._received_times
        while True:
            while received:
                message = to_message(received.popleft(), times.popleft())
                if self._matches_filters(message):
                    return message
            # recv(0) too runs what is due at this instant: a frame sent now is on the wire now
            # (python-can's virtual bus hands over a queued frame); one the latency holds back
            # is not due yet
            if not scheduler.run_until(lambda: received, end):
                return None

    def _recv_internal(self, timeout: float | None) -> tuple[can.Message | None, bool]:
        message = self.recv(timeout)
        return message, True

    def _send_periodic_internal(
            self, msgs: Sequence[can.Message] | can.Message, period: float,
            duration: float | None = None, autostart: bool = True,
            modifier_callback: Callable[[can.Message], None] | None = None,
    ) -> SimulatedCyclicTask:
        return SimulatedCyclicTask(self, msgs, period, duration, autostart, modifier_callback)

    def clear_received(self) -> None:
        self._received.clear()
        self._received_times.clear()

    def shutdown(self) -> None:
        """Detach from the wire, stop the notifiers still reading this bus (their threads
        end) and undo the virtual waits the bus installed."""
        self._detach()
        self._closed.set()
        notifiers, self._notifiers = self._notifiers, []
        for notifier in notifiers:
            if not notifier.stopped:
                notifier.stop()
        while self._undo_waits:
            self._undo_waits.pop()()
        super().shutdown()


class SimulatedCyclicTask(LimitedDurationCyclicSendTaskABC, ModifiableCyclicTaskABC,
                          RestartableCyclicTaskABC):
    """``bus.send_periodic`` on a simulated bus: a timer on the virtual clock. As python-can's
    thread does: the first message at ``start()``, one every ``period`` after, until ``stop()``
    or ``duration``; a send that fails (the bus is down) is logged and stops the task."""

    def __init__(self, bus: SimulatedBus, messages: Sequence[can.Message] | can.Message,
                 period: float, duration: float | None, autostart: bool,
                 modifier_callback: Callable[[can.Message], None] | None) -> None:
        check_time("period", period)
        if period <= 0:
            raise ValueError(f"period must be > 0 seconds, got {period}")
        if duration is not None:
            check_time("duration", duration, 0)
        super().__init__(messages, period, duration)
        self.bus = bus
        self.modifier_callback = modifier_callback
        self._timer: Any = None
        self._index = 0
        if autostart:
            self.start()

    def start(self) -> None:
        if self._timer is not None:
            return
        scheduler = self.bus.scheduler
        self.end_time = scheduler.clock() + self.duration if self.duration else None
        self._timer = scheduler.call_every(self.period, self._send_next)

    def stop(self) -> None:
        if self._timer is not None:
            self._timer.cancel()
            self._timer = None

    def _send_next(self) -> None:
        if self.end_time is not None and self.bus.scheduler.clock() >= self.end_time:
            self.stop()
            return
        message = self.messages[self._index]
        try:
            if self.modifier_callback is not None:
                self.modifier_callback(message)
            self.bus.send(message)
        except can.CanError as error:
            log.warning("periodic message %03Xh stopped: %s", message.arbitration_id, error)
            self.stop()
            return
        self._index = (self._index + 1) % len(self.messages)
