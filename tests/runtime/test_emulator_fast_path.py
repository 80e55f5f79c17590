"""The emulator's direct delivery (a COB-ID one twin alone listens to goes straight to that
twin) and the port's reuse of a frame's Message: everything that observes a frame still sees
it, and the binding follows the twins (added, rebooted, renumbered, powered off)."""

from __future__ import annotations

import ctypes
import random
import sys
import threading
import time
import uuid
from collections.abc import Callable, Iterator

import can
import pytest

from blinkcan.protocol import Frame
from blinkcan.runtime import Emulator, to_frame, to_message
from blinkcan.runtime.canport import CanBusPort, reuses_messages
from blinkcan.runtime.emulator import LOOP_TIMER_SLACK_NS, set_timer_slack
from blinkcan.testing import Rig
from blinkcan.twin import KeypadTwin
from blinkcan.twin.base import CanopenTwin

#: prctl(2): the calling thread's timer slack, nanoseconds
_PR_GET_TIMERSLACK = 30
READ_1000 = bytes.fromhex("4000100000000000")


@pytest.fixture
def channel() -> str:
    return f"fast-{uuid.uuid4().hex}"


@pytest.fixture
def host(channel: str) -> Iterator[can.BusABC]:
    bus = can.Bus(interface="virtual", channel=channel)
    yield bus
    bus.shutdown()


@pytest.fixture
def device_bus(channel: str) -> Iterator[can.BusABC]:
    bus = can.Bus(interface="virtual", channel=channel)
    yield bus
    bus.shutdown()


def replies(host: can.BusABC, can_id: int, window: float) -> list[Frame]:
    """Every frame ``can_id`` heard within ``window`` seconds."""
    frames = []
    end = time.monotonic() + window
    while (left := end - time.monotonic()) > 0:
        message = host.recv(left)
        if message is not None and message.arbitration_id == can_id:
            frame = to_frame(message)
            assert frame is not None
            frames.append(frame)
    return frames


def read(host: can.BusABC, node_id: int, window: float = 0.3) -> list[Frame]:
    """The replies to one read of 1000h/00 at ``node_id``."""
    host.send(to_message(Frame(0x600 + node_id, READ_1000)))
    return replies(host, 0x580 + node_id, window)


def test_a_tap_and_a_twin_watcher_see_every_sdo_request(host: can.BusABC,
                                                        device_bus: can.BusABC) -> None:
    twin = KeypadTwin()
    tapped: list[Frame] = []
    watched: list[Frame] = []
    with Emulator(device_bus, [twin]) as emulator:
        assert len(read(host, 0x15)) == 1  # bound before the hooks come
        emulator.on_frame = lambda frame, sent, now: None if sent else tapped.append(frame)
        emulator.run(lambda now: twin.watch_frames(lambda frame, now: watched.append(frame)))
        for _ in range(3):
            assert [reply.data[0] for reply in read(host, 0x15)] == [0x43]
    request = Frame(0x615, READ_1000)
    assert tapped.count(request) == 3
    assert watched.count(request) == 3


@pytest.mark.parametrize("boot_up", [1, 0])
def test_a_twin_added_at_the_same_node_id_hears_the_requests_too(
        host: can.BusABC, device_bus: can.BusABC, boot_up: int) -> None:
    with Emulator(device_bus, [KeypadTwin()], power_up_spread=0) as emulator:
        assert len(read(host, 0x15)) == 1
        # without a boot-up frame, nothing is sent when it comes (no send refreshes the
        # emulator's routes on the way)
        emulator.add(KeypadTwin(settings={"boot_up_service": boot_up}))
        assert len(read(host, 0x15)) == 2  # both devices answer (a wiring mistake)


def test_the_binding_follows_a_new_node_id_and_the_power(host: can.BusABC,
                                                          device_bus: can.BusABC) -> None:
    twin = KeypadTwin()
    with Emulator(device_bus, [twin]) as emulator:
        assert len(read(host, 0x15)) == 1
        emulator.run(lambda now: twin.use_node_id(0x21))
        assert read(host, 0x15, window=0.2) == []
        assert len(read(host, 0x21)) == 1
        emulator.power_off(twin)
        assert read(host, 0x21, window=0.2) == []
        emulator.power_on(twin)  # boots with its stored node id again
        assert len(read(host, 0x15)) == 1
        assert read(host, 0x21, window=0.2) == []


def test_a_response_delay_set_while_running_applies_to_the_next_requests(
        host: can.BusABC, device_bus: can.BusABC) -> None:
    with Emulator(device_bus, [KeypadTwin()]) as emulator:
        assert len(read(host, 0x15)) == 1
        emulator.response_delay = 0.1
        request = to_message(Frame(0x615, READ_1000))
        sent = time.monotonic()
        host.send(request)
        host.send(request)  # arrives while the keypad is still answering: dropped
        answered = replies(host, 0x595, window=0.4)
        assert len(answered) == 1
        assert time.monotonic() - sent >= 0.1


class _KeepingBus(can.BusABC):
    """A bus that keeps every Message it was given (as a queueing driver might)."""

    def __init__(self) -> None:
        super().__init__(channel="keep")
        self.kept: list[can.Message] = []

    def send(self, msg: can.Message, timeout: float | None = None) -> None:
        self.kept.append(msg)

    def _recv_internal(self, timeout: float | None) -> tuple[None, bool]:
        time.sleep(timeout or 0)
        return None, False


def test_a_bus_that_may_keep_a_message_gets_a_new_one_per_send() -> None:
    bus = _KeepingBus()
    try:
        assert not reuses_messages(bus)
        times = iter([1.0, 2.0])
        port = CanBusPort(bus, clock=lambda: next(times))
        frame = Frame(0x595, bytes.fromhex("4300100009000000"))
        port.send(frame)
        port.send(frame)
        first, second = bus.kept
        assert first is not second
        assert (first.timestamp, second.timestamp) == (1.0, 2.0)
    finally:
        bus.shutdown()


def test_equal_frames_sent_twice_arrive_twice_each_with_its_time(channel: str,
                                                                  host: can.BusABC) -> None:
    bus = can.Bus(interface="virtual", channel=channel, preserve_timestamps=True)
    reusing = can.Bus(interface="virtual", channel=channel)
    try:
        assert not reuses_messages(bus)  # the message's own time is what arrives
        assert reuses_messages(reusing)
        for sender in (bus, reusing):
            times = iter([1.0, 2.0])
            port = CanBusPort(sender, clock=lambda times=times: next(times))  # type: ignore[misc]
            frame = Frame(0x595, bytes.fromhex("4300100009000000"))
            port.send(frame)
            port.send(frame)
            first, second = host.recv(1), host.recv(1)
            assert first is not None
            assert second is not None
            assert to_frame(first) == to_frame(second) == frame
            if sender is bus:
                assert (first.timestamp, second.timestamp) == (1.0, 2.0)
    finally:
        bus.shutdown()
        reusing.shutdown()


def test_a_bus_that_may_keep_a_message_gets_python_cans_own_data_type() -> None:
    """Only a bus done with the Message when its send returns gets a kept Message whose data
    are the frame's own bytes; any other gets a Message as python-can makes it (a bytearray:
    a driver that queues it may read it as one)."""
    bus = _KeepingBus()
    try:
        CanBusPort(bus).send(Frame(0x595, bytes.fromhex("4300100009000000")))
        (kept,) = bus.kept
        assert type(kept.data) is bytearray
        assert kept.data == bytes.fromhex("4300100009000000")
    finally:
        bus.shutdown()


def _arrivals_of_a_kept_message(sender: can.BusABC, receiver: can.BusABC) -> None:
    """A reusing port sends one frame three times; each arrival is python-can's own Message
    (its data a bytearray, the receiver's to change) equal to the frame, also after a
    receiver changed an earlier arrival's data."""
    assert reuses_messages(sender)
    port = CanBusPort(sender)
    frame = Frame(0x595, bytes.fromhex("4300100009000000"))
    for _ in range(3):
        port.send(frame)
        arrived = receiver.recv(2)
        assert arrived is not None
        assert type(arrived.data) is bytearray
        assert (arrived.arbitration_id, bytes(arrived.data), arrived.dlc) == (0x595, frame.data, 8)
        assert to_frame(arrived) == frame
        arrived.data[0] = 0xFF  # the receiver's own copy: the next sending is unchanged
    assert frame.data == bytes.fromhex("4300100009000000")


def test_a_kept_message_arrives_as_python_cans_own_on_a_virtual_bus(
        channel: str, host: can.BusABC) -> None:
    sender = can.Bus(interface="virtual", channel=channel)
    try:
        _arrivals_of_a_kept_message(sender, host)
    finally:
        sender.shutdown()


@pytest.mark.multiprocess
def test_a_kept_message_arrives_as_python_cans_own_on_udp_multicast() -> None:
    group = f"239.74.{random.randint(1, 254)}.{random.randint(1, 254)}"
    port = random.randint(40000, 60000)
    try:
        sender, receiver = (can.Bus(interface="udp_multicast", channel=group, port=port,
                                    hop_limit=0) for _ in range(2))
    except (OSError, ImportError, can.CanError) as error:
        pytest.skip(f"udp_multicast unavailable here ({error})")
    try:
        _arrivals_of_a_kept_message(sender, receiver)
    finally:
        sender.shutdown()
        receiver.shutdown()


def _echoing_bus() -> can.BusABC:
    channel = f"239.74.{random.randint(1, 254)}.{random.randint(1, 254)}"
    try:
        return can.Bus(interface="udp_multicast", channel=channel,
                       port=random.randint(40000, 60000), hop_limit=0)
    except (OSError, ImportError, can.CanError) as error:
        pytest.skip(f"udp_multicast unavailable here ({error})")


@pytest.mark.multiprocess
def test_an_echoing_port_drops_each_echo_once_and_never_an_old_sendings_equal() -> None:
    """The port's reader checks the echo of its own frames itself (OwnFrames.is_echo's usual
    case inlined): each sending's echo is dropped once, within the window; an equal frame
    after the window, or once every echo came, is another node's and reaches the handlers."""
    bus = _echoing_bus()
    try:
        now = [0.0]
        port = CanBusPort(bus, clock=lambda: now[0])
        heard: list[tuple[Frame, float]] = []
        detach = port.listen(lambda frame, at: heard.append((frame, at)))
        bus.send = lambda msg, timeout=None: None  # type: ignore[method-assign]  # no real echo
        feed = port._listener.on_message_received
        frame = Frame(0x595, bytes.fromhex("4300100009000000"))

        def arrives(at: float) -> None:
            now[0] = at
            feed(to_message(frame))

        port.send(frame)
        port.send(frame)
        arrives(0.5)  # the first sending's echo
        arrives(0.6)  # the second's
        arrives(0.7)  # another node's equal frame
        assert heard == [(frame, 0.7)]
        port.send(frame)  # at 0.7, its echo never comes
        port.send(frame)
        arrives(2.8)  # past the window for both: another node's
        now[0] = 2.85
        port.send(frame)
        arrives(2.9)  # within the window of the last sending: its echo
        assert heard == [(frame, 0.7), (frame, 2.8)]
        detach()
    finally:
        bus.shutdown()


def test_the_twins_cannot_be_changed_by_hand_and_the_error_names_add(
        host: can.BusABC, device_bus: can.BusABC) -> None:
    """A twin swapped into ``emulator.twins`` by hand would miss the emulator's bookkeeping
    (its power-up, timers and the COB-ID binding: requests went to the old twin), so every
    change of the list by hand is refused with a TypeError that names Emulator.add; the
    list is unchanged and the twins still answer."""
    twin = KeypadTwin()
    other = KeypadTwin()
    with Emulator(device_bus, [twin]) as emulator:
        assert len(read(host, 0x15)) == 1
        changes: dict[str, Callable[[list[CanopenTwin]], object]] = {
            "swap": lambda twins: twins.__setitem__(0, other),
            "slice": lambda twins: twins.__setitem__(slice(0, 1), [other]),
            "delete": lambda twins: twins.__delitem__(0),
            "append": lambda twins: twins.append(other),
            "extend": lambda twins: twins.extend([other]),
            "insert": lambda twins: twins.insert(0, other),
            "remove": lambda twins: twins.remove(twin),
            "pop": lambda twins: twins.pop(),
            "clear": lambda twins: twins.clear(),
            "sort": lambda twins: twins.sort(key=id),
            "reverse": lambda twins: twins.reverse(),
            "+=": lambda twins: twins.__iadd__([other]),
            "*=": lambda twins: twins.__imul__(2),
        }
        for name, change in changes.items():
            with pytest.raises(TypeError, match=r"Emulator\.add"):
                change(emulator.twins)
            assert list(emulator.twins) == [twin], name
        with pytest.raises(TypeError, match=r"Emulator\.add"):
            emulator.twins = [other]
        assert emulator.twins == [twin]
        assert isinstance(emulator.twins, list)  # reads as before: a list
        assert len(read(host, 0x15)) == 1  # the twin given still answers, alone
        emulator.add(other)  # the way in: powered on, bound, answering
        assert emulator.twins == [twin, other]
        assert len(read(host, 0x15)) == 2


class _Pinger:
    """A device (duck-typed) that sends 100h every ``period`` from t=0 and, hearing 101h,
    moves its next frame to ``nudge`` after that moment."""

    node_id = 0x01
    period = 0.01
    nudge = 0.004

    def __init__(self) -> None:
        self.listening = {0x101: None}
        self.next: float | None = None

    def power_on(self, now: float) -> list[Frame]:
        self.next = now
        return []

    def advance(self, now: float) -> list[Frame]:
        assert self.next is not None
        if now < self.next:
            return []
        self.next += self.period
        return [Frame(0x100, b"\x01")]

    def next_deadline(self) -> float | None:
        return self.next

    def receive(self, frame: Frame, now: float) -> list[Frame]:
        self.next = now + self.nudge
        return []

    def is_sdo_request(self, frame: Frame) -> bool:
        return False


class _Answerer(_Pinger):
    """Answers 100h with 101h at once; no schedule."""

    node_id = 0x02

    def __init__(self) -> None:
        super().__init__()
        self.listening = {0x100: None}

    def next_deadline(self) -> float | None:
        return None

    def receive(self, frame: Frame, now: float) -> list[Frame]:
        return [Frame(0x101, b"")]


def test_a_deadline_moved_by_the_answer_to_a_periodic_frame_is_the_one_kept() -> None:
    """A twin's due frames are sent before its next deadline is planned: an answer they
    draw at once from another twin may move that deadline meanwhile (the pinger's next
    frame comes 4 ms after each answer, not 10 ms), and no timer of the old plan fires."""
    with Rig() as rig:
        rig.emulator.add(_Pinger())  # type: ignore[arg-type]
        rig.emulator.add(_Answerer())  # type: ignore[arg-type]
        rig.advance(0.0405)
        pings = [round(timed.time, 9) for timed in rig.frames if timed.frame.can_id == 0x100]
        answers = [timed for timed in rig.frames if timed.frame.can_id == 0x101]
    assert pings == [0.0, 0.004, 0.008, 0.012, 0.016, 0.02, 0.024, 0.028, 0.032, 0.036,
                     0.04]
    assert len(answers) == len(pings)


def test_a_hook_sees_every_periodic_frame_sent_before_the_next_deadline_is_planned() -> None:
    """The tap sees each periodic frame as it is sent, in order, on time (simulated)."""
    seen: list[tuple[int, float]] = []
    with Rig() as rig:
        twin = rig.add(KeypadTwin(settings={"producer_heartbeat_time": 10}))
        rig.emulator.on_frame = lambda frame, sent, now: seen.append((frame.can_id, now))
        start = rig.now
        rig.advance(0.1)
        sent = [(timed.frame.can_id, timed.time) for timed in rig.frames_since(start)
                if timed.time > start]  # the boot-up went before the hook
    heartbeats = [at for can_id, at in seen if can_id == 0x700 + twin.node_id]
    assert len(heartbeats) == 10
    assert seen == sent


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="timer slack is Linux's")
def test_the_emulators_own_loop_thread_alone_gets_the_small_timer_slack(
        device_bus: can.BusABC) -> None:
    """Given a bus, the emulator's loop thread asks for LOOP_TIMER_SLACK_NS; the caller's
    thread, and the loop of a port the caller gave, keep theirs."""
    libc = ctypes.CDLL(None)

    def slack(now: float = 0.0) -> int:
        return int(libc.prctl(_PR_GET_TIMERSLACK, 0, 0, 0, 0))

    probe = threading.Thread(target=lambda: allowed.append(set_timer_slack(2_000)))
    allowed: list[bool] = []
    probe.start()
    probe.join()
    if allowed != [True]:
        pytest.skip("this system refuses prctl(PR_SET_TIMERSLACK) (a sandbox)")
    mine = slack()
    with Emulator(device_bus, [KeypadTwin()]) as emulator:
        assert emulator.run(slack) == LOOP_TIMER_SLACK_NS
        assert slack() == mine
    port = CanBusPort(device_bus, name="callers")
    port.scheduler.start()
    try:
        before = port.scheduler.run(slack)
        with Emulator(port, [KeypadTwin()]) as emulator:
            assert emulator.run(slack) == before
    finally:
        port.scheduler.stop()


def test_a_timer_slack_below_one_nanosecond_is_refused_by_name() -> None:
    """0 would silently restore the kernel's default slack: refused, as any value below 1."""
    for nanoseconds in (0, -5):
        with pytest.raises(ValueError, match=r">= 1 ns"):
            set_timer_slack(nanoseconds)
