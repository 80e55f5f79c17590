"""Issue 17 items 3 and 4: one reader behaviour for the drivers and the emulator on a messy
bus: undecodable frames are counted and dropped, never slow the reader; a failing bus backs
off; a shut-down bus stops every reader."""

from __future__ import annotations

import logging
import random
import socket
import threading
import time
import uuid

import can
import pytest

from blinkcan.host import Keybox
from blinkcan.runtime import Emulator
from blinkcan.runtime.canbus import BusReader
from blinkcan.twin import KeyboxTwin


def _multicast(channel: str, port: int) -> can.BusABC:
    try:
        return can.Bus(interface="udp_multicast", channel=channel, port=port, hop_limit=0)
    except (OSError, ImportError, can.CanError) as error:
        pytest.skip(f"udp_multicast unavailable here ({error})")


@pytest.fixture
def group() -> tuple[str, int]:
    return f"239.74.{random.randint(1, 254)}.{random.randint(1, 254)}", random.randint(40000, 60000)


def _junk(group: tuple[str, int], count: int) -> None:
    """``count`` datagrams that are no python-can frame, from a plain UDP socket."""
    sender = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:
        sender.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_TTL, 0)  # this machine only
        for n in range(count):
            sender.sendto(b"\x01not a frame %d" % n, group)
    finally:
        sender.close()


@pytest.mark.multiprocess
def test_undecodable_datagrams_are_counted_and_dropped_and_never_slow_the_reader(
        group: tuple[str, int], caplog: pytest.LogCaptureFixture) -> None:
    device_bus, host_bus = _multicast(*group), _multicast(*group)
    emulator = Emulator(device_bus, [KeyboxTwin(node_id=0x0C)]).start()
    try:
        with caplog.at_level(logging.INFO, logger="blinkcan"):
            box = Keybox(host_bus, 0x0C)
            health: list[str] = []
            box.on_health(lambda event: health.append(event.kind))
            _junk(group, 30)  # a burst: the old per-error back-off slept ~25 s on it
            time.sleep(0.2)
            assert box.state(4) == "off"  # answered at once, within the 0.5 s SDO timeout
            box.on(4)
            assert box.state(4) == "high"
            reading = box.host.reading
            box.close()
            emulator.stop()
        assert reading.undecodable == 30
        assert emulator.stats.reading.undecodable == 30
        assert reading.failures == 0
        assert emulator.stats.reading.failures == 0
        assert health == []  # no false lost / back
        warnings = [r.getMessage() for r in caplog.records if r.levelno >= logging.WARNING]
        assert len(warnings) == 4, warnings  # host and emulator: the first one, the count
        assert len([w for w in warnings if "cannot decode" in w]) == 2
        assert len([w for w in warnings if "30 frames that could not be decoded" in w]) == 2
    finally:
        emulator.stop()
        device_bus.shutdown()
        host_bus.shutdown()


class _FailingBus(can.BusABC):
    """A bus whose every read fails (an unplugged adapter), counting the reads."""

    def __init__(self) -> None:
        self.reads = 0
        super().__init__(channel="failing")

    def _recv_internal(self, timeout: float | None) -> tuple[can.Message | None, bool]:
        self.reads += 1
        raise can.CanOperationError("adapter unplugged")

    def send(self, msg: can.Message, timeout: float | None = None) -> None:
        raise can.CanOperationError("adapter unplugged")


def test_a_failing_bus_is_read_with_a_back_off_and_reported_once(
        caplog: pytest.LogCaptureFixture) -> None:
    bus = _FailingBus()
    heard: list[can.Message] = []
    with caplog.at_level(logging.INFO, logger="blinkcan"):
        reader = BusReader(bus, can.BufferedReader())
        try:
            time.sleep(0.5)
        finally:
            reader.stop()
            bus.shutdown()
    assert heard == []
    assert 1 <= bus.reads <= 10  # 0.02 + 0.04 + 0.08 + 0.16 + 0.32 s ... not a busy loop
    assert reader.stats.failures == bus.reads
    assert reader.stats.undecodable == 0
    assert [r.levelname for r in caplog.records] == ["ERROR"]


@pytest.mark.parametrize("interface", ["virtual", "udp_multicast"])
def test_an_emulator_stops_reading_a_shut_down_bus(
        interface: str, group: tuple[str, int], caplog: pytest.LogCaptureFixture) -> None:
    bus = (can.Bus(interface="virtual", channel=f"closing-{uuid.uuid4().hex}")
           if interface == "virtual" else _multicast(*group))
    emulator = Emulator(bus, [KeyboxTwin(node_id=0x0C)]).start()
    try:
        with caplog.at_level(logging.DEBUG, logger="blinkcan.runtime"):
            bus.shutdown()
            time.sleep(0.5)
        reads = [r.getMessage() for r in caplog.records if r.levelno >= logging.ERROR]
        assert len(reads) == 1
        assert "was shut down" in reads[0]
        assert emulator.stats.reading.closed
        assert not [t for t in threading.enumerate() if t.name.startswith("can.notifier")
                    and t.is_alive() and getattr(t, "_args", (None,))[0] is bus]
    finally:
        emulator.stop()
