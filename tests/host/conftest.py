"""Twins in an Emulator on a virtual bus, a HostBus for the drivers, and a sniffer."""

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
    sniffer: can.BusABC
    generation: str = "1.1"
    channel: str = ""  # the virtual channel, for a command line pointed at this bus

    @property
    def firmware(self) -> str:
        return "V2.8" if self.generation == "1.5" else "V2.2"

    def sniffed(self, settle: float = 0.05) -> list[Frame]:
        """Frames seen on the bus since the last call."""
        time.sleep(settle)
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


@pytest.fixture(params=[("firmware", "1.1"), ("cia301", "1.1"), ("firmware", "1.5")],
                ids=["firmware", "cia301", "generation2"])
def rig(request: pytest.FixtureRequest) -> Iterator[Rig]:
    """Every driver test runs against both quirk profiles and both keypad generations."""
    quirks, generation = request.param
    channel = f"host-{uuid.uuid4().hex}"
    buses = [can.Bus(interface="virtual", channel=channel) for _ in range(3)]
    keypad = quiet_keypad(quirks, manual=generation)
    keybox = KeyboxTwin(quirks=quirks)
    emulator = Emulator(buses[0], [keypad, keybox])
    host = HostBus(buses[1])
    with emulator, host:
        rig = Rig(emulator, host, keypad, keybox, buses[2], generation, channel)
        rig.sniffed()
        yield rig
    for bus in buses:
        bus.shutdown()
