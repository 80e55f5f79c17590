"""A test bench in simulated time: twins, your controller's drivers and the wire, in one thread.

``Rig()`` makes a :class:`~blinkcan.runtime.scheduler.SimulatedScheduler`, a simulated wire
and an :class:`~blinkcan.runtime.Emulator` on it. ``rig.bus`` is a python-can bus for your
controller, whatever it is written with: give it to ``Keypad``/``Keybox``, send and receive on
it yourself, or hand it to another library as it is: ``canopen.Network(rig.bus).connect()``,
a cantools ``Tester``, a ``can.Notifier`` with your listeners. The rig drives their notifier in
your thread, in simulation order, and their blocking waits (an SDO reply, a heartbeat,
``Tester.expect``) run the simulation in virtual time (``runtime.simbus`` and
``runtime.virtual_waits`` say how; ``rig.close()`` stops those notifiers and puts the waits
back). Nothing sleeps: ``rig.advance(60)`` runs a minute of the devices' life in a fraction
of a second, a driver call that waits for a reply runs the simulation until the reply (or
its timeout, in virtual seconds), and the same scenario gives the same frames at the same
times every run.

Fault injection is here in one place: power, fuses, inputs, keys, heartbeats, frames dropped or
delayed, an SDO server too busy to answer, a bus that goes away. Every fault and input call
takes the twin, or the node id a twin on this rig answers at; anything else is a TypeError.

The simulation runs in one thread, the one that made the Rig: ``rig.bus.recv()`` from another
thread (a reader thread, as on a real bus) is refused with :class:`WrongThreadError`, since it
would run the simulation and move the clock under that thread; ``rig.bus.send()`` too, since it
would write the wire log and the simulation's queue from there. Put a ``can.Notifier`` on
``rig.bus`` instead: the rig hands its listeners every frame, in order, in the rig's thread.
So are a driver's calls from another thread (its sends and waits), and an asyncio driver's
in an event loop of another thread: run the loop in the rig's thread (``asyncio.run`` in the
test); nothing is sent and the clock does not move.

An exception raised in your handlers (a driver's ``on_key``/``subscribe`` callbacks) or in work
handed to ``host.spawn`` is raised again, with its traceback, from the rig or driver call that
ran the simulation when it happened; one still pending is raised by :meth:`Rig.close`. Every
time argument must be a finite number of seconds (ValueError otherwise).
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Iterable
from typing import Any, TypeVar

import can

from blinkcan.host.events import LONGEST_EVENT_WAIT
from blinkcan.protocol.cob import HEARTBEAT, check_node_id, check_time
from blinkcan.protocol.frame import Frame
from blinkcan.runtime.emulator import Emulator
from blinkcan.runtime.scheduler import SimulatedScheduler, WrongThreadError
from blinkcan.runtime.simbus import SimulatedBus, SimulatedNetwork
from blinkcan.runtime.wire_log import TimedFrame, WireLog
from blinkcan.twin.base import CanopenTwin

__all__ = ["Rig", "RigBus", "WrongThreadError", "frames_of"]  # the error's home is runtime

T = TypeVar("T")
W = TypeVar("W", bound=CanopenTwin)


class RigBus(SimulatedBus):
    """``rig.bus``: the controller's endpoint, whose ``recv()`` runs the simulation and whose
    ``send()`` writes the wire log and the scheduler's queue, so both are the rig's thread's
    only (a ``can.Notifier``'s own thread still parks in recv, see ``runtime.simbus``; its
    listeners and ``send_periodic`` tasks run in the rig's thread, so they send)."""

    def __init__(self, network: SimulatedNetwork, channel: str,
                 owner: threading.Thread) -> None:
        super().__init__(network, channel)
        self.owner = owner

    def send(self, msg: can.Message, timeout: float | None = None) -> None:
        me = threading.current_thread()
        if me is not self.owner:
            raise WrongThreadError(
                f"rig.bus.send() from thread {me.name!r}: it puts the frame on the rig's wire, "
                f"which is the thread's that made the Rig ({self.owner.name!r}), and would "
                "change the wire log and the simulation's queue under it. Send from that "
                "thread: a can.Notifier's listeners and bus.send_periodic() run there")
        super().send(msg, timeout)

    def recv(self, timeout: float | None = None) -> can.Message | None:
        me = threading.current_thread()
        # python-can names a notifier's thread after the bus: the simulation parks it
        if me is not self.owner and not me.name.endswith(f'for bus "{self.channel_info}"'):
            raise WrongThreadError(
                f"rig.bus.recv() from thread {me.name!r}: it runs the rig's simulation, which "
                f"is the thread's that made the Rig ({self.owner.name!r}), and would move its "
                "clock under it. Call recv() in that thread, or put a can.Notifier(rig.bus, "
                "[listener]) on the bus: the rig hands the listener every frame, in order")
        return super().recv(timeout)


class Rig:
    """Twins and drivers on one simulated bus; see the module docstring.

    ``latency``: seconds each frame takes on the wire (0: delivered at the time it is sent,
    still after the frames sent before it). ``response_delay``: every twin answers that late,
    and drops an SDO request that comes while it is still answering one (real keypads do).
    """

    def __init__(self, *, start: float = 0.0, latency: float = 0.0,
                 response_delay: float = 0.0) -> None:
        check_time("start", start)
        check_time("latency", latency, 0)
        check_time("response_delay", response_delay, 0)
        self.scheduler = SimulatedScheduler(start)
        self.network = SimulatedNetwork(self.scheduler, latency)
        self._twins_bus = SimulatedBus(self.network, "twins")
        # twins in phase: a twin added at t boots at t, as the test says (no power-up spread)
        self.emulator = Emulator(self._twins_bus, [], response_delay=response_delay,
                                 power_up_spread=0.0)
        self.emulator.start()
        #: the controller's bus: any python-can code and blinkcan driver takes it
        self.bus: SimulatedBus = RigBus(self.network, "controller", threading.current_thread())
        # from now on the simulation runs, and the drivers' ports send, in this thread only
        # (the twins' port, made above, sends inside the simulation: no check per frame)
        self.scheduler.owner = threading.current_thread()
        self._closed = False

    # -- time -------------------------------------------------------------------------------

    @property
    def now(self) -> float:
        """Virtual seconds."""
        return self.scheduler.clock()

    @property
    def frames(self) -> WireLog:
        """Every frame that went on the wire, in order, with its virtual time: read it as a
        list of :class:`TimedFrame` (index, slice, iterate, ``len``, compare with a list)."""
        return self.network.frames

    def frames_since(self, start: float) -> list[TimedFrame]:
        check_time("start", start)
        return self.network.frames.since(start)

    def advance(self, seconds: float) -> None:
        """Run ``seconds`` of virtual time."""
        self.scheduler.run_until(None, self.now + check_time("seconds", seconds, 0))

    def settle(self, limit: float = 1.0) -> None:
        """Run until no frame is in flight, no delayed reply waits and nothing else is due
        now; at most ``limit`` virtual seconds (periodic frames do not keep it busy)."""
        end = self.now + check_time("limit", limit, 0)
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
        if it did not within ``timeout`` virtual seconds (0 to :data:`LONGEST_EVENT_WAIT`, the
        event iterators' bound: a longer one ran a busy rig for ever; else ValueError)."""
        start = self.now
        if check_time("timeout", timeout, 0) > LONGEST_EVENT_WAIT:
            raise ValueError(f"timeout must be from 0 to {LONGEST_EVENT_WAIT:g} virtual seconds, "
                             f"not {timeout!r}")
        if not self.scheduler.run_until(predicate, start + timeout):
            raise AssertionError(f"condition not met within {timeout} virtual s "
                                 f"(from t={start:.3f} to t={self.now:.3f})")
        return self.now

    # -- twins ------------------------------------------------------------------------------

    def add(self, twin: W) -> W:
        """Put ``twin`` on the bus, powered on now."""
        if not isinstance(twin, CanopenTwin):
            raise TypeError(f"rig.add takes a twin, not {type(twin).__name__}")
        self.emulator.add(twin)
        return twin

    @property
    def twins(self) -> tuple[CanopenTwin, ...]:
        """The twins on this rig, in the order they were added."""
        return tuple(self.emulator.twins)

    def twin(self, device: CanopenTwin | int) -> CanopenTwin:
        """The twin ``device`` names: a twin on this rig, or the node id one of them answers
        at. TypeError for anything else; ValueError for a twin not on this rig, or a node id
        no twin (or more than one) answers at."""
        if isinstance(device, CanopenTwin):
            if not any(device is twin for twin in self.emulator.twins):
                raise ValueError(f"this {type(device).__name__} is not on the rig: "
                                 "rig.add(twin) it first")
            return device
        node_id = self._node_id(device)
        found = [twin for twin in self.emulator.twins if twin.node_id == node_id]
        if len(found) != 1:
            nodes = ", ".join(f"{twin.node_id:02X}h" for twin in self.emulator.twins) or "none"
            raise ValueError(f"{len(found) or 'no'} twins answer at node {node_id:02X}h on this "
                             f"rig; pass the twin (twins at: {nodes})")
        return found[0]

    @staticmethod
    def _node_id(device: object) -> int:
        if isinstance(device, bool) or not isinstance(device, int):
            raise TypeError(f"a twin or a node id (int) is needed, not {type(device).__name__}")
        return check_node_id(device)

    def _able(self, device: CanopenTwin | int, action: str) -> Any:
        """The twin ``device`` names, if it can do ``action`` (TypeError if it cannot)."""
        twin = self.twin(device)
        if not callable(getattr(twin, action, None)):
            raise TypeError(f"a {type(twin).__name__} has no {action}()")
        return twin

    def act(self, action: Callable[[float], T]) -> T:
        """Run ``action(now)`` on a twin (``lambda now: kp.press(3, now)``); the frames it
        returns go on the bus as the device's, and everything they cause at this instant
        (the drivers' handlers) has run when this returns.

        Frames already sent reach the twins first (:meth:`catch_up`): with no latency a frame
        arrives at the time it was sent, so a press right after ``Keypad(rig.bus, ...)`` comes
        after the driver's NMT start, to an operational keypad, as on a real bus."""
        self.catch_up()
        result = self.emulator.run(action)
        self.catch_up()
        return result

    def catch_up(self) -> None:
        """Run what is due at this instant (frames sent and not yet delivered, the handlers
        they call), not moving the clock; nothing when called from inside the simulation (a
        handler: what is due runs after it)."""
        if not self.scheduler.in_loop:
            self.scheduler.run_until(None, self.now)

    def snapshot(self, device: CanopenTwin | int) -> dict[str, Any]:
        """The twin's :meth:`snapshot` once the frames already sent have reached it
        (:meth:`catch_up`)."""
        twin = self.twin(device)
        self.catch_up()
        return twin.snapshot()

    # -- fault injection and inputs: a twin, or the node id it answers at ---------------------

    def power_off(self, device: CanopenTwin | int) -> None:
        twin = self.twin(device)
        self.act(lambda now: twin.power_off())

    def power_on(self, device: CanopenTwin | int) -> None:
        self.act(self.twin(device).power_on)

    def power_cycle(self, device: CanopenTwin | int, off_time: float = 0.1) -> None:
        """Off for ``off_time`` virtual seconds, then on (boot-up, stored settings back)."""
        twin = self.twin(device)
        check_time("off_time", off_time, 0)
        self.power_off(twin)
        self.advance(off_time)
        self.power_on(twin)

    def press(self, device: CanopenTwin | int, key: int) -> None:
        twin = self._able(device, "press")
        self.act(lambda now: twin.press(key, now))

    def release(self, device: CanopenTwin | int, key: int) -> None:
        twin = self._able(device, "release")
        self.act(lambda now: twin.release(key, now))

    def tap(self, device: CanopenTwin | int, key: int, hold: float = 0.1) -> None:
        """Press ``key``, hold it ``hold`` virtual seconds, release it."""
        twin = self._able(device, "press")
        check_time("hold", hold, 0)
        self.press(twin, key)
        self.advance(hold)
        self.release(twin, key)

    def long_press(self, device: CanopenTwin | int, key: int, hold: float = 1.0) -> None:
        self.tap(device, key, hold)

    def turn(self, device: CanopenTwin | int, encoder: int, ticks: int) -> None:
        """Turn an encoder by ``ticks`` (> 0 clockwise)."""
        twin = self._able(device, "turn")
        self.act(lambda now: twin.turn(encoder, ticks, now))

    def set_analog(self, device: CanopenTwin | int, input: int, volts: float) -> None:
        twin = self._able(device, "set_analog")
        self.act(lambda now: twin.set_analog(input, volts, now))

    def set_digital_input(self, device: CanopenTwin | int, input: int, level: bool) -> None:
        twin = self._able(device, "set_digital_input")
        self.act(lambda now: twin.set_digital_input(input, level, now))

    def blow_fuse(self, device: CanopenTwin | int, pin: int) -> None:
        twin = self._able(device, "blow_fuse")
        self.act(lambda now: twin.blow_fuse(pin, now))

    def replace_fuse(self, device: CanopenTwin | int, pin: int) -> None:
        twin = self._able(device, "replace_fuse")
        self.act(lambda now: twin.replace_fuse(pin, now))

    def set_input(self, device: CanopenTwin | int, pin: int, level: bool) -> None:
        twin = self._able(device, "set_input")
        self.act(lambda now: twin.set_input(pin, level, now))

    def drop(self, match: Callable[[Frame], bool]) -> Callable[[], None]:
        """Drop every frame ``match`` accepts until the returned function is called."""
        if not callable(match):
            raise TypeError(f"match must be a function of a frame, not {type(match).__name__}")
        return self.network.add_rule(lambda frame: "drop" if match(frame) else None)

    def delay(self, match: Callable[[Frame], bool], seconds: float) -> Callable[[], None]:
        """Delay every frame ``match`` accepts by ``seconds``; call the result to stop."""
        if not callable(match):
            raise TypeError(f"match must be a function of a frame, not {type(match).__name__}")
        check_time("seconds", seconds, 0)
        return self.network.add_rule(lambda frame: seconds if match(frame) else None)

    def _node_of(self, device: CanopenTwin | int) -> Callable[[], int]:
        """The node id ``device`` names, read when a frame passes: a twin's in use (it may
        change), or a node id (any device's, the controller's too)."""
        if isinstance(device, CanopenTwin):
            twin = self.twin(device)
            return lambda: twin.node_id
        node_id = self._node_id(device)
        return lambda: node_id

    def drop_node(self, device: CanopenTwin | int) -> Callable[[], None]:
        """Drop every frame of a device's COB-IDs (xxx + node id, 11-bit) until undone."""
        node = self._node_of(device)
        return self.drop(lambda frame: not frame.extended and frame.can_id > 0x80
                         and frame.can_id & 0x7F == node())

    def stop_heartbeat(self, device: CanopenTwin | int) -> Callable[[], None]:
        """Drop a device's heartbeat frames (700h + node id) until the result is called."""
        node = self._node_of(device)
        return self.drop(lambda frame: not frame.extended and frame.can_id == HEARTBEAT + node())

    def busy(self, response_delay: float) -> None:
        """Every twin answers ``response_delay`` s late and drops SDO requests meanwhile."""
        self.emulator.response_delay = check_time("response_delay", response_delay, 0)

    def bus_down(self) -> None:
        """The bus goes away: nothing is delivered and sending raises ``can.CanOperationError``."""
        self.network.up = False

    def bus_up(self) -> None:
        self.network.up = True

    # -- lifecycle ----------------------------------------------------------------------------

    def close(self) -> None:
        """Stop the twins and the buses; an exception a handler raised and no call has raised
        yet is raised here."""
        if not self._closed:
            self._closed = True
            self.emulator.stop()
            self.bus.shutdown()
            self._twins_bus.shutdown()
        self.scheduler.raise_failures()

    def __enter__(self) -> Rig:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()


def frames_of(timed: Iterable[TimedFrame]) -> list[Frame]:
    """Just the frames of ``rig.frames`` (or a slice of it)."""
    return [frame for _, frame in timed]
