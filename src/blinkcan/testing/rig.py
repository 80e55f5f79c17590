"""A test bench in simulated time: twins, your controller's drivers and the wire, in one thread.

``Rig()`` makes a :class:`~blinkcan.runtime.scheduler.SimulatedScheduler`, a simulated wire
and an :class:`~blinkcan.runtime.Emulator` on it. ``rig.bus`` is a python-can bus for your
controller: give it to ``Keypad``/``Keybox`` (or send and receive on it yourself). Nothing
sleeps: ``rig.advance(60)`` runs a minute of the devices' life in a fraction of a second, a
driver call that waits for a reply runs the simulation until the reply (or its timeout, in
virtual seconds), and the same scenario gives the same frames at the same times every run.

Fault injection is here in one place: power, fuses, inputs, keys, heartbeats, frames dropped or
delayed, an SDO server too busy to answer, a bus that goes away.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from typing import Any, TypeVar

from blinkcan.protocol.cob import HEARTBEAT
from blinkcan.protocol.frame import Frame
from blinkcan.runtime.emulator import Emulator
from blinkcan.runtime.scheduler import SimulatedScheduler
from blinkcan.runtime.simbus import SimulatedBus, SimulatedNetwork, TimedFrame
from blinkcan.twin.base import CanopenTwin

T = TypeVar("T")
W = TypeVar("W", bound=CanopenTwin)


class Rig:
    """Twins and drivers on one simulated bus; see the module docstring.

    ``latency``: seconds each frame takes on the wire (0: delivered at the time it is sent,
    still after the frames sent before it). ``response_delay``: every twin answers that late,
    and drops an SDO request that comes while it is still answering one (real keypads do).
    """

    def __init__(self, *, start: float = 0.0, latency: float = 0.0,
                 response_delay: float = 0.0) -> None:
        self.scheduler = SimulatedScheduler(start)
        self.network = SimulatedNetwork(self.scheduler, latency)
        self._twins_bus = SimulatedBus(self.network, "twins")
        self.emulator = Emulator(self._twins_bus, [], response_delay=response_delay)
        self.emulator.start()
        #: the controller's bus: any python-can code and blinkcan driver takes it
        self.bus = SimulatedBus(self.network, "controller")
        self._closed = False

    # -- time -------------------------------------------------------------------------------

    @property
    def now(self) -> float:
        """Virtual seconds."""
        return self.scheduler.clock()

    @property
    def frames(self) -> list[TimedFrame]:
        """Every frame that went on the wire, in order, with its virtual time."""
        return self.network.frames

    def frames_since(self, start: float) -> list[TimedFrame]:
        return [timed for timed in self.network.frames if timed.time >= start]

    def advance(self, seconds: float) -> None:
        """Run ``seconds`` of virtual time."""
        if seconds < 0:
            raise ValueError(f"seconds must be >= 0, got {seconds}")
        self.scheduler.run_until(None, self.now + seconds)

    def settle(self, limit: float = 1.0) -> None:
        """Run until no frame is in flight, no delayed reply waits and nothing else is due
        now; at most ``limit`` virtual seconds (periodic frames do not keep it busy)."""
        end = self.now + limit
        emulator = self.emulator
        while self.now <= end:
            self.scheduler.run_until(None, self.now)  # everything due at this instant
            if not self.network.in_flight and not emulator.pending_replies:
                return
            due = self.scheduler.next_due()
            if due is None or due > end:
                break
            self.scheduler.step(end)
        self.scheduler.run_until(None, self.now)

    def until(self, predicate: Callable[[], object], timeout: float = 1.0) -> float:
        """Run until ``predicate()`` holds and return the virtual time it did; AssertionError
        if it did not within ``timeout`` virtual seconds."""
        start = self.now
        if not self.scheduler.run_until(predicate, start + timeout):
            raise AssertionError(f"condition not met within {timeout} virtual s "
                                 f"(from t={start:.3f} to t={self.now:.3f})")
        return self.now

    # -- twins ------------------------------------------------------------------------------

    def add(self, twin: W) -> W:
        """Put ``twin`` on the bus, powered on now."""
        self.emulator.add(twin)
        return twin

    def act(self, action: Callable[[float], T]) -> T:
        """Run ``action(now)`` on a twin (``lambda now: kp.press(3, now)``); the frames it
        returns go on the bus as the device's, and everything they cause at this instant
        (the drivers' handlers) has run when this returns."""
        result = self.emulator.run(action)
        if not self.scheduler.in_loop:
            self.scheduler.run_until(None, self.now)
        return result

    def snapshot(self, twin: CanopenTwin) -> dict[str, Any]:
        return twin.snapshot()

    # -- fault injection ----------------------------------------------------------------------

    def power_off(self, twin: CanopenTwin) -> None:
        self.act(lambda now: twin.power_off())

    def power_on(self, twin: CanopenTwin) -> None:
        self.act(twin.power_on)

    def power_cycle(self, twin: CanopenTwin, off_time: float = 0.1) -> None:
        """Off for ``off_time`` virtual seconds, then on (boot-up, stored settings back)."""
        self.power_off(twin)
        self.advance(off_time)
        self.power_on(twin)

    def press(self, twin: Any, key: int) -> None:
        self.act(lambda now: twin.press(key, now))

    def release(self, twin: Any, key: int) -> None:
        self.act(lambda now: twin.release(key, now))

    def tap(self, twin: Any, key: int, hold: float = 0.1) -> None:
        """Press ``key``, hold it ``hold`` virtual seconds, release it."""
        self.press(twin, key)
        self.advance(hold)
        self.release(twin, key)

    def long_press(self, twin: Any, key: int, hold: float = 1.0) -> None:
        self.tap(twin, key, hold)

    def blow_fuse(self, twin: Any, pin: int) -> None:
        self.act(lambda now: twin.blow_fuse(pin, now))

    def replace_fuse(self, twin: Any, pin: int) -> None:
        self.act(lambda now: twin.replace_fuse(pin, now))

    def set_input(self, twin: Any, pin: int, level: bool) -> None:
        self.act(lambda now: twin.set_input(pin, level, now))

    def drop(self, match: Callable[[Frame], bool]) -> Callable[[], None]:
        """Drop every frame ``match`` accepts until the returned function is called."""
        return self.network.add_rule(lambda frame: "drop" if match(frame) else None)

    def delay(self, match: Callable[[Frame], bool], seconds: float) -> Callable[[], None]:
        """Delay every frame ``match`` accepts by ``seconds``; call the result to stop."""
        if seconds < 0:
            raise ValueError(f"seconds must be >= 0, got {seconds}")
        return self.network.add_rule(lambda frame: seconds if match(frame) else None)

    def drop_node(self, node_id: int) -> Callable[[], None]:
        """Drop every frame of a device's COB-IDs (xxx + node id, 11-bit) until undone."""
        return self.drop(lambda frame: not frame.extended and frame.can_id & 0x7F == node_id
                         and frame.can_id > 0x80)

    def stop_heartbeat(self, node_id: int) -> Callable[[], None]:
        """Drop node ``node_id``'s heartbeat frames (700h + id) until the result is called."""
        cob_id = HEARTBEAT + node_id
        return self.drop(lambda frame: frame.can_id == cob_id and not frame.extended)

    def busy(self, response_delay: float) -> None:
        """Every twin answers ``response_delay`` s late and drops SDO requests meanwhile."""
        if response_delay < 0:
            raise ValueError(f"response_delay must be >= 0 seconds, got {response_delay}")
        self.emulator.response_delay = response_delay

    def bus_down(self) -> None:
        """The bus goes away: nothing is delivered and sending raises ``can.CanOperationError``."""
        self.network.up = False

    def bus_up(self) -> None:
        self.network.up = True

    # -- lifecycle ----------------------------------------------------------------------------

    def close(self) -> None:
        if not self._closed:
            self._closed = True
            self.emulator.stop()
            self.bus.shutdown()
            self._twins_bus.shutdown()

    def __enter__(self) -> Rig:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()


def frames_of(timed: Iterable[TimedFrame]) -> list[Frame]:
    """Just the frames of ``rig.frames`` (or a slice of it)."""
    return [frame for _, frame in timed]
