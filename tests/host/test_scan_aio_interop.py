"""scan(), the asyncio API, and sharing a bus with a python-canopen Network."""

from __future__ import annotations

import asyncio
import uuid
from collections.abc import Iterator

import can
import canopen
import pytest

import blinkcan
from blinkcan.host import AsyncKeybox, AsyncKeypad, HostBus, Keypad, async_scan, scan
from blinkcan.runtime import Emulator
from blinkcan.twin import KeyboxTwin
from tests.host.conftest import FLAVOUR_IDS, FLAVOURS, Rig, quiet_keypad, simulated_rig


@pytest.fixture(params=FLAVOURS, ids=FLAVOUR_IDS)
def sim(request: pytest.FixtureRequest) -> Iterator[Rig]:
    yield from simulated_rig(request)


def test_scan_finds_both_models_with_their_versions(sim: Rig) -> None:
    """In simulated time: the 0.1 s timeouts hold however busy the machine is."""
    rig = sim
    found = scan(rig.host, listen=0.05, timeout=0.1, node_ids=range(1, 32))
    assert [(f.node_id, f.kind, f.model_id, f.software_version) for f in found] == [
        (0x0C, "keybox", "Keybox3", "1.00"), (0x15, "keypad", "PKP2600SI", rig.firmware)]


def test_scan_hears_boot_ups_on_its_own_bus() -> None:
    channel = f"scan-{uuid.uuid4().hex}"
    device_bus, host_bus = (can.Bus(interface="virtual", channel=channel) for _ in range(2))
    try:
        twin = KeyboxTwin(node_id=0x21)
        emulator = Emulator(device_bus, [twin])
        with emulator:
            emulator.run(lambda now: twin.receive(
                blinkcan.Frame(0x621, bytes.fromhex("2B17100032000000")), now))
            found = blinkcan.scan(host_bus, listen=0.1, timeout=0.1, node_ids=range(0x20, 0x23))
        assert [(f.node_id, f.kind, f.heard) for f in found] == [(0x21, "keybox", True)]
    finally:
        device_bus.shutdown()
        host_bus.shutdown()


def test_asyncio_api_has_the_same_names(rig: Rig) -> None:
    async def main() -> None:
        keypad = AsyncKeypad(rig.host)
        keybox = AsyncKeybox(rig.host)
        identity = await keypad.identity()
        assert identity.software_version == rig.firmware
        await keybox.on(2)
        assert await keybox.state(2) == "high"
        events = keypad.events(timeout=1.0)
        # the keypad sends its key state once started (PKP §10): wait for the driver's NMT
        # start to reach it, however loaded the machine (a fixed 0.05 s was flaky)
        await asyncio.to_thread(rig.wait_until, lambda: rig.emulator.snapshot(rig.keypad)[
            "nmt_state"] == "operational")
        rig.emulator.press(rig.keypad, 9)
        event = await events.__anext__()
        assert (event.key, event.action) == (9, "press")
        found = await async_scan(rig.host, listen=0.01, timeout=0.1, node_ids=range(0x0C, 0x0D))
        assert [f.kind for f in found] == ["keybox"]

    asyncio.run(main())


def test_drivers_share_a_bus_with_a_python_canopen_network() -> None:
    channel = f"network-{uuid.uuid4().hex}"
    device_bus = can.Bus(interface="virtual", channel=channel)
    network = canopen.Network()
    network.connect(interface="virtual", channel=channel)
    try:
        with Emulator(device_bus, [quiet_keypad()]):
            host = HostBus(network=network).start()  # a listener of the Network's notifier
            assert host.bus is network.bus
            keypad = Keypad(host)
            assert keypad.identity().model_id == "PKP2600SI"
            sdo = network.add_node(0x15).sdo  # the Network still works beside the driver
            assert sdo.upload(0x1018, 1) == b"\xe2\x03\x00\x00"
            host.stop()
    finally:
        network.disconnect()
        device_bus.shutdown()
