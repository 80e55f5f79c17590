"""The simulated port: an endpoint of a ``SimulatedNetwork`` as a
:class:`~blinkcan.runtime.port.Port`, in the simulation's virtual time.

Frames are handed to the handlers by the simulation itself, on its one thread, at the virtual
time they arrive; the port's scheduler is the network's ``SimulatedScheduler``. Where that
scheduler has an owner thread (a Rig's), the port sends from that thread only. A simulated
endpoint never receives its own frames (a real controller does not either), so there is no
echo to drop, and it never shuts down under its users.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from threading import get_ident

import can

from blinkcan.protocol.frame import Frame
from blinkcan.runtime.canbus import ReadStats
from blinkcan.runtime.scheduler import WrongThreadError
from blinkcan.runtime.simbus import FrameHandler, SimulatedBus


class SimulatedPort:
    """The port of the simulated endpoint ``bus``."""

    #: send a frame: the endpoint's own send (the emulator calls it for every frame)
    send: Callable[[Frame], None]

    def __init__(self, bus: SimulatedBus) -> None:
        self.bus = bus
        self.scheduler = bus.scheduler
        self.reading = ReadStats()
        owner = self.scheduler.owner
        self.send = bus.send_frame if owner is None else _in_thread_of(owner, bus.send_frame)

    def listen(self, handler: FrameHandler, on_closed: Callable[[], object] | None = None
               ) -> Callable[[], None]:
        return self.bus.add_frame_listener(handler)

    def listeners(self) -> list[FrameHandler]:
        return self.bus.frame_listeners()


def _in_thread_of(owner: threading.Thread, send: Callable[[Frame], None]
                  ) -> Callable[[Frame], None]:
    """``send``, refused (:class:`WrongThreadError`, nothing sent) from another thread than
    ``owner``: a frame written from another thread would change the wire log and the
    simulation's queue under the thread that runs it. A Rig's drivers' ports have it; the
    twins' (whose frames are sent inside the simulation, in its thread) need not."""
    def send_in_owner_thread(frame: Frame) -> None:
        if get_ident() != owner.ident:
            raise WrongThreadError.of("a send on the simulated bus", owner)
        send(frame)

    return send_in_owner_thread


def simulated_port(bus: can.BusABC) -> SimulatedPort | None:
    """The simulated port of ``bus`` if it is a simulated endpoint, else None (the one
    place that asks: everything else takes a port)."""
    return SimulatedPort(bus) if isinstance(bus, SimulatedBus) else None
