"""The emulator's direct delivery (a COB-ID one twin alone listens to goes straight to that
twin) and the port's reuse of a frame's Message: everything that observes a frame still sees
it, and the binding follows the twins (added, rebooted, renumbered, powered off)."""

from __future__ import annotations

import random
import time
import uuid
from collections.abc import Iterator

import can
import pytest

from blinkcan.protocol import Frame
from blinkcan.runtime import Emulator, to_frame, to_message
from blinkcan.runtime.canport import CanBusPort, reuses_messages
from blinkcan.twin import KeypadTwin

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
