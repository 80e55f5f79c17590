"""A CAN bus in simulated time: frames delivered in order, at the virtual time they were sent.

:class:`SimulatedNetwork` is the wire: every frame sent is recorded with its time and handed to
every other endpoint through the :class:`SimulatedScheduler`, never to its sender (a real
controller does not receive its own frames). :class:`SimulatedBus` is one endpoint with
python-can's ``BusABC`` interface, so drivers and application code take it like any bus; the
Emulator and the host drivers attach frame handlers directly and skip ``can.Message``.

Fault injection lives on the wire: rules that drop or delay frames, and a bus that goes away.
"""

from __future__ import annotations

import collections
from collections.abc import Callable
from functools import partial
from typing import Any, NamedTuple

import can

from blinkcan.protocol.cob import check_time
from blinkcan.protocol.frame import Frame
from blinkcan.runtime.canbus import to_frame, to_message
from blinkcan.runtime.scheduler import SimulatedScheduler

FrameHandler = Callable[[Frame, float], None]
#: virtual seconds ``recv()`` without a timeout waits at most
RECV_FOREVER = 60.0
#: a wire rule: for a frame, None (unchanged), "drop", or extra delay in seconds
Rule = Callable[[Frame], "str | float | None"]


_timed = tuple.__new__  # TimedFrame without its __new__: a frame and a time made here


class TimedFrame(NamedTuple):
    """A frame as it went on the wire at virtual time ``time``."""

    time: float
    frame: Frame

    def __str__(self) -> str:
        return f"{self.time:10.6f}  {self.frame}"


class SimulatedNetwork:
    """The shared wire of one simulation."""

    def __init__(self, scheduler: SimulatedScheduler, latency: float = 0.0) -> None:
        check_time("latency", latency, 0)
        self.scheduler = scheduler
        self.latency = latency
        self.frames: list[TimedFrame] = []
        self.up = True
        #: the endpoints' handlers, a tuple: delivery reads it for every frame, attach and
        #: detach (rare) replace it
        self._endpoints: tuple[FrameHandler, ...] = ()
        self._rules: list[Rule] = []
        self.in_flight = 0

    def attach(self, handler: FrameHandler) -> Callable[[], None]:
        """Deliver every frame sent by others to ``handler(frame, now)``; returns the detach."""
        self._endpoints += (handler,)

        def detach() -> None:
            endpoints = list(self._endpoints)
            if handler in endpoints:
                endpoints.remove(handler)
                self._endpoints = tuple(endpoints)

        return detach

    def add_rule(self, rule: Rule) -> Callable[[], None]:
        """A rule that may drop or delay frames; returns the function that removes it."""
        self._rules.append(rule)
        return lambda: self._rules.remove(rule) if rule in self._rules else None

    def transmit(self, frame: Frame, sender: FrameHandler | None) -> None:
        """Put ``frame`` on the wire; raises ``can.CanOperationError`` when the bus is gone."""
        if not self.up:
            raise can.CanOperationError("the simulated bus is down")
        delay = self.latency
        for rule in self._rules:
            verdict = rule(frame)
            if verdict == "drop":
                return
            if isinstance(verdict, (int, float)):
                delay += float(verdict)
        scheduler = self.scheduler
        if delay:
            self.in_flight += 1
            scheduler.call_later(delay, lambda: self._deliver(frame, sender, True))
        else:
            self._deliver(frame, sender, False)

    def _deliver(self, frame: Frame, sender: FrameHandler | None, delayed: bool) -> None:
        if delayed:
            self.in_flight -= 1
        if not self.up:
            return
        scheduler = self.scheduler
        self.frames.append(_timed(TimedFrame, (scheduler.clock(), frame)))
        handover = self._handover
        for handler in self._endpoints:  # a tuple: an endpoint attached meanwhile waits
            if handler != sender:  # bound methods: equal, not identical, per access
                self.in_flight += 1
                scheduler.call_soon(partial(handover, handler, frame))

    def _handover(self, handler: FrameHandler, frame: Frame) -> None:
        self.in_flight -= 1
        if self.up:
            handler(frame, self.scheduler.clock())


class SimulatedBus(can.BusABC):
    """One endpoint of a :class:`SimulatedNetwork`, with python-can's bus interface.

    ``recv(timeout)`` runs the simulation until a frame arrives or ``timeout`` virtual seconds
    passed (``recv()`` with no timeout: at most :data:`RECV_FOREVER`). Do not give it to a
    ``can.Notifier``: the simulation has no threads.
    """

    def __init__(self, network: SimulatedNetwork, channel: str = "simulated",
                 **kwargs: Any) -> None:
        super().__init__(channel=channel, **kwargs)
        self.network = network
        self.scheduler = network.scheduler
        self.channel_info = f"simulated bus {channel}"
        self._received: collections.deque[TimedFrame] = collections.deque(maxlen=100_000)
        self._listeners: list[FrameHandler] = []
        self._detach = network.attach(self._on_frame)

    def add_frame_listener(self, handler: FrameHandler) -> Callable[[], None]:
        """Call ``handler(frame, now)`` for every frame this endpoint receives."""
        self._listeners.append(handler)
        return lambda: self._listeners.remove(handler) if handler in self._listeners else None

    def frame_listeners(self) -> list[FrameHandler]:
        """The handlers :meth:`add_frame_listener` attached."""
        return list(self._listeners)

    def _on_frame(self, frame: Frame, now: float) -> None:
        self._received.append(_timed(TimedFrame, (now, frame)))
        for listener in self._listeners:
            listener(frame, now)

    def send_frame(self, frame: Frame) -> None:
        self.network.transmit(frame, self._on_frame)

    def send(self, msg: can.Message, timeout: float | None = None) -> None:
        frame = to_frame(msg)
        if frame is None:
            raise can.CanOperationError("the simulated bus carries data frames of up to 8 bytes")
        self.send_frame(frame)

    def recv(self, timeout: float | None = None) -> can.Message | None:
        """The next frame received (filters applied), running the simulation until it comes
        or ``timeout`` virtual seconds passed (None: at most :data:`RECV_FOREVER`)."""
        received = self._received
        scheduler = self.scheduler
        if timeout is not None:  # NaN is refused; +inf waits as None does
            check_time("timeout", timeout, infinite=True)
        wait = RECV_FOREVER if timeout is None or timeout == float("inf") else max(0.0, timeout)
        end = scheduler.clock() + wait
        while True:
            while received:
                when, frame = received.popleft()
                message = to_message(frame, when)
                if self._matches_filters(message):
                    return message
            if scheduler.clock() >= end or not scheduler.run_until(lambda: received, end):
                return None

    def _recv_internal(self, timeout: float | None) -> tuple[can.Message | None, bool]:
        message = self.recv(timeout)
        return message, True

    def clear_received(self) -> None:
        self._received.clear()

    def shutdown(self) -> None:
        self._detach()
        super().shutdown()
