"""Issue 17 item 5: a cancelled call of an asyncio driver cancels that call only."""

from __future__ import annotations

import asyncio
import uuid
from collections.abc import Iterator

import can
import pytest

from blinkcan.host import AsyncKeybox, AsyncKeypad
from blinkcan.runtime import Emulator
from blinkcan.twin import KeyboxTwin, KeypadTwin


@pytest.fixture
def bus() -> Iterator[tuple[can.BusABC, Emulator, KeyboxTwin]]:
    channel = f"aio-cancel-{uuid.uuid4().hex}"
    device_bus = can.Bus(interface="virtual", channel=channel)
    host_bus = can.Bus(interface="virtual", channel=channel)
    keybox = KeyboxTwin(node_id=0x0C)
    emulator = Emulator(device_bus, [keybox, KeypadTwin(node_id=0x15)]).start()
    yield host_bus, emulator, keybox
    emulator.stop()
    host_bus.shutdown()
    device_bus.shutdown()


def _pin(twin: KeyboxTwin, pin: int) -> str:
    return str(twin.snapshot()["pins"][pin - 1]["state"])


def test_a_call_cancelled_while_the_driver_opens_leaves_the_driver_working(
        bus: tuple[can.BusABC, Emulator, KeyboxTwin]) -> None:
    host_bus, _emulator, twin = bus

    async def main() -> None:
        box = AsyncKeybox(host_bus, 0x0C)  # opens in a worker thread
        with pytest.raises(asyncio.TimeoutError):
            await asyncio.wait_for(box.on(1), 0.001)  # a caller's timeout
        await box.on(2)  # was: CancelledError, for every later call
        assert await box.state(2) == "high"
        with pytest.raises(asyncio.TimeoutError):
            await asyncio.wait_for(box.open(), 0.0)
        await box.off(2)
        await box.__aexit__(None, None, None)

    asyncio.run(main())
    assert _pin(twin, 2) == "off"


def test_an_iterator_cancelled_while_the_driver_opens_leaves_the_driver_working(
        bus: tuple[can.BusABC, Emulator, KeyboxTwin]) -> None:
    host_bus = bus[0]

    async def main() -> str:
        keypad = AsyncKeypad(host_bus, 0x15)
        events = keypad.events(timeout=1.0)
        with pytest.raises(asyncio.TimeoutError):
            await asyncio.wait_for(events.__anext__(), 0.001)
        generation = str(await keypad.generation)
        await keypad.__aexit__(None, None, None)
        return generation

    assert asyncio.run(main()) == "1.1"
