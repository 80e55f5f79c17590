"""The transport: a :class:`Port` sends frames, calls a handler for the frames it receives,
and owns the scheduler its users run on.

``HostBus`` and ``Emulator`` take a Port and never ask which one it is (DESIGN.md, "Extension
points"). Two are built in: the python-can port (``runtime.canport``: any python-can bus, read
by a notifier thread) and the simulated port (``runtime.simport``: an endpoint of a
``SimulatedNetwork``, in virtual time). :func:`port_for` is the one place that picks the port
for a python-can bus object.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import NamedTuple, Protocol, runtime_checkable

import can

from blinkcan.protocol.frame import Frame
from blinkcan.runtime.canbus import ReadStats
from blinkcan.runtime.canport import CanBusPort
from blinkcan.runtime.scheduler import Scheduler
from blinkcan.runtime.simport import simulated_port

#: ``handler(frame, now)``: a frame received, at the port's clock time ``now``
FrameHandler = Callable[[Frame, float], None]


@runtime_checkable
class Port(Protocol):
    """A transport for frames.

    Handlers run in the port's receiving context: the reader thread of a real bus, the
    simulation itself on a simulated one (then ``scheduler.in_loop`` is true there). A
    handler must be quick; work that touches its owner's state goes through
    ``scheduler.deliver`` (on the loop: at once when it is idle, else queued).
    """

    @property
    def scheduler(self) -> Scheduler:
        """The scheduler the port's users run their timers and handlers on."""

    @property
    def reading(self) -> ReadStats:
        """What reading met: undecodable frames, failures, a shut-down bus."""

    def send(self, frame: Frame) -> None:
        """Put ``frame`` on the bus; ``can.CanError`` when it cannot go."""

    def listen(self, handler: FrameHandler, on_closed: Callable[[], object] | None = None
               ) -> Callable[[], None]:
        """Call ``handler(frame, now)`` for every frame received from others (never the
        port's own); ``on_closed()`` once the bus was shut down. Returns the detach."""

    def listeners(self) -> list[FrameHandler]:
        """The handlers that ports of this same bus object feed (to find a shared user)."""


def port_for(bus: can.BusABC, *, notifier: can.Notifier | None = None,
             clock: Callable[[], float] = time.monotonic, name: str = "blinkcan") -> Port:
    """The port of a python-can bus object: the simulated port for a simulated endpoint,
    else the python-can port (its own real-time scheduler named ``name`` on ``clock``; reads
    through ``notifier`` if given, else the notifier already on the bus, else its own)."""
    simulated = simulated_port(bus)
    if simulated is not None:
        return simulated
    return CanBusPort(bus, notifier=notifier, clock=clock, name=name)


class Taken(NamedTuple):
    """What a HostBus or an Emulator was given, as a port: the python-can bus (None for a
    port), the port, and whether the port was made here (so its user stops it)."""

    bus: can.BusABC | None
    port: Port
    owned: bool


def take_port(bus: can.BusABC | Port, *, notifier: can.Notifier | None = None,
              clock: Callable[[], float] = time.monotonic, name: str = "blinkcan") -> Taken:
    """A port given stays the caller's; a python-can bus gets a port of its own
    (:func:`port_for`), owned by whoever took it."""
    if isinstance(bus, can.BusABC):
        return Taken(bus, port_for(bus, notifier=notifier, clock=clock, name=name), True)
    return Taken(None, bus, False)
