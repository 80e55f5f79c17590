"""The transport port (runtime/port.py): one interface for a python-can bus and a simulated
endpoint; HostBus and the Emulator take either and never ask which."""

from __future__ import annotations

import threading
import time
import uuid
from collections.abc import Iterator

import can
import pytest

from blinkcan.host import HostBus
from blinkcan.protocol import Frame
from blinkcan.runtime import Emulator
from blinkcan.runtime.port import Port, port_for
from blinkcan.runtime.scheduler import RealTimeScheduler, SimulatedScheduler
from blinkcan.runtime.simbus import SimulatedBus, SimulatedNetwork
from blinkcan.twin import KeypadTwin


@pytest.fixture
def channel() -> str:
    return f"test-{uuid.uuid4().hex}"


@pytest.fixture
def buses(channel: str) -> Iterator[tuple[can.BusABC, can.BusABC]]:
    pair = (can.Bus(interface="virtual", channel=channel),
            can.Bus(interface="virtual", channel=channel))
    yield pair
    for bus in pair:
        bus.shutdown()


@pytest.fixture
def simulated_pair() -> Iterator[tuple[SimulatedBus, SimulatedBus]]:
    network = SimulatedNetwork(SimulatedScheduler())
    pair = (SimulatedBus(network, "a"), SimulatedBus(network, "b"))
    yield pair
    for bus in pair:  # python-can warns of a bus never shut down
        bus.shutdown()


def _until(scheduler_simulated: bool, port: Port, condition: threading.Event) -> bool:
    if scheduler_simulated:
        return port.scheduler.wait(condition, 1.0)
    return condition.wait(2.0)


@pytest.mark.parametrize("simulated", [False, True], ids=["python-can", "simulated"])
def test_a_port_hands_others_frames_to_its_handlers_never_its_own(
        simulated: bool, buses: tuple[can.BusABC, can.BusABC],
        simulated_pair: tuple[SimulatedBus, SimulatedBus]) -> None:
    first, second = simulated_pair if simulated else buses
    mine, theirs = port_for(first), port_for(second)
    assert isinstance(mine, Port)
    assert mine.scheduler.simulated == simulated
    got: list[Frame] = []
    arrived = threading.Event() if not simulated else mine.scheduler.signal()

    def handler(frame: Frame, now: float) -> None:
        got.append(frame)
        arrived.set()

    detach = mine.listen(handler)
    assert handler in port_for(first).listeners()  # another port of the same bus sees it
    try:
        mine.send(Frame(0x123, b"own"))
        theirs.send(Frame(0x321, b"theirs"))
        assert _until(simulated, mine, arrived)  # type: ignore[arg-type]
        if not simulated:
            time.sleep(0.05)  # an own frame would have come back by now
        assert got == [Frame(0x321, b"theirs")]
    finally:
        detach()
    assert handler not in port_for(first).listeners()


def test_the_emulator_calls_its_twins_on_the_schedulers_loop(
        buses: tuple[can.BusABC, can.BusABC]) -> None:
    device_bus, host_bus = buses
    twin = KeypadTwin()
    on_loop: list[bool] = []
    emulator = Emulator(device_bus, [twin])
    receive = twin.receive

    def watched(frame: Frame, now: float) -> list[Frame]:
        on_loop.append(emulator.scheduler.in_loop)
        return receive(frame, now)

    twin.receive = watched  # type: ignore[method-assign]
    with emulator, HostBus(host_bus) as host:
        assert host.sdo(twin.node_id).upload(0x1000, 0)
    assert on_loop
    assert all(on_loop)


@pytest.mark.parametrize("simulated", [False, True], ids=["python-can", "simulated"])
def test_host_bus_and_emulator_take_a_port(
        simulated: bool, buses: tuple[can.BusABC, can.BusABC],
        simulated_pair: tuple[SimulatedBus, SimulatedBus]) -> None:
    device_bus, host_bus = simulated_pair if simulated else buses
    device_port, host_port = port_for(device_bus), port_for(host_bus)
    twin = KeypadTwin()
    with Emulator(device_port, [twin]), HostBus(host_port) as host:
        assert host.port is host_port
        assert host.bus is None
        assert host.sdo(twin.node_id).upload(0x1018, 1)
        assert HostBus.attach(host_port) is host  # found again through the port's bus
        assert HostBus.attach(host_bus) is host
        host.release()
        host.release()
    for port in (device_port, host_port):
        assert isinstance(port.scheduler, SimulatedScheduler) or (
            isinstance(port.scheduler, RealTimeScheduler) and port.scheduler.running)
    for port in (device_port, host_port):  # the ports stay their maker's
        port.scheduler.stop()
