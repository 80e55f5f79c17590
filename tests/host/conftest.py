"""Twins in an Emulator, a HostBus for the drivers, and a sniffer: on a virtual bus in real
time (the threaded path), or on blinkcan.testing's simulated bus (``simulated_rig``), where
waits and sleeps run virtual time."""

from __future__ import annotations

import time
import uuid
from collections.abc import Callable, Iterator
from dataclasses import dataclass

import can
import pytest

from blinkcan.host import HostBus
from blinkcan.protocol import Frame
from blinkcan.runtime import Emulator, to_frame
from blinkcan.testing import Rig as Bench
from blinkcan.twin import KeyboxTwin, KeypadTwin


def quiet_keypad(quirks: str = "firmware", node_id: int = 0x15, manual: str = "1.1"
                 ) -> KeypadTwin:
    """A keypad whose stored startup show is off, so LEDs show what was commanded."""
    twin = KeypadTwin(node_id=node_id, quirks=quirks, manual=manual)  # type: ignore[arg-type]
    twin.power_on(0.0)
    twin.receive(Frame(0x600 + node_id, bytes.fromhex("2F14200000000000")), 0.0)
    twin.power_off()
    return twin


@dataclass
class Rig:
    emulator: Emulator
    host: HostBus
    keypad: KeypadTwin
    keybox: KeyboxTwin
    sniffer: can.BusABC | _Sniffer
    generation: str = "1.1"
    bench: Bench | None = None  # set when the rig runs in simulated time
    channel: str = ""  # the virtual channel, for a command line pointed at this bus

    @property
    def firmware(self) -> str:
        return "V2.8" if self.generation == "1.5" else "V2.2"

    def sleep(self, seconds: float) -> None:
        if self.bench is not None:
            self.bench.advance(seconds)
        else:
            time.sleep(seconds)

    def wait_until(self, condition: Callable[[], object], timeout: float = 2.0) -> None:
        if self.bench is not None:
            self.bench.until(condition, timeout)
        else:
            wait_until(condition, timeout)

    def sniffed(self, settle: float = 0.05) -> list[Frame]:
        """Frames seen on the bus since the last call."""
        self.sleep(settle)
        frames = []
        while (message := self.sniffer.recv(0)) is not None:
            frame = to_frame(message)
            if frame is not None:
                frames.append(frame)
        return frames


def wait_until(condition: Callable[[], object], timeout: float = 2.0) -> None:
    end = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > end:
            raise AssertionError("condition not met in time")
        time.sleep(0.005)


FLAVOURS = [("firmware", "1.1"), ("cia301", "1.1"), ("firmware", "1.5")]
FLAVOUR_IDS = ["firmware", "cia301", "generation2"]


@pytest.fixture(params=FLAVOURS, ids=FLAVOUR_IDS)
def rig(request: pytest.FixtureRequest) -> Iterator[Rig]:
    """Every driver test runs against both quirk profiles and both keypad generations."""
    yield from threaded_rig(request)


def threaded_rig(request: pytest.FixtureRequest) -> Iterator[Rig]:
    """The rig on a virtual bus in real time: threads, python-can's notifier."""
    quirks, generation = request.param
    channel = f"host-{uuid.uuid4().hex}"
    buses = [can.Bus(interface="virtual", channel=channel) for _ in range(3)]
    keypad = quiet_keypad(quirks, manual=generation)
    keybox = KeyboxTwin(quirks=quirks)
    emulator = Emulator(buses[0], [keypad, keybox])
    host = HostBus(buses[1])
    with emulator, host:
        rig = Rig(emulator, host, keypad, keybox, buses[2], generation, channel=channel)
        rig.sniffed()
        yield rig
    for bus in buses:
        bus.shutdown()


def simulated_rig(request: pytest.FixtureRequest) -> Iterator[Rig]:
    """The same rig in simulated time (use as a fixture body, with the same params)."""
    quirks, generation = request.param
    with Bench() as bench:
        keypad = bench.add(quiet_keypad(quirks, manual=generation))
        keybox = bench.add(KeyboxTwin(quirks=quirks))
        host = HostBus(bench.bus)
        with host:
            rig = Rig(bench.emulator, host, keypad, keybox, _Sniffer(bench), generation,
                      bench=bench)
            rig.sniffed()
            yield rig


class _Sniffer:
    """The frames on a simulated wire since the last call, like a listening bus."""

    def __init__(self, bench: Bench) -> None:
        self._bench = bench
        self._seen = 0

    def recv(self, timeout: float | None = None) -> can.Message | None:
        frames = self._bench.frames
        if self._seen >= len(frames):
            return None
        when, frame = frames[self._seen]
        self._seen += 1
        return can.Message(arbitration_id=frame.can_id, data=frame.data,
                           is_extended_id=frame.extended, timestamp=when)
