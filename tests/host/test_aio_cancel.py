"""Issue 17 item 5: a cancelled call of an asyncio driver cancels that call only."""

from __future__ import annotations

import asyncio
import uuid
from collections.abc import Callable, Iterator
from typing import Any

import can
import pytest

from blinkcan.host import AsyncKeybox, AsyncKeypad, Keybox, SdoTimeoutError
from blinkcan.runtime import Emulator
from blinkcan.testing import Rig
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


# -- a cancelled output command: the picture says what the Keybox confirmed ----------------------

#: the download acknowledge of 2001h/02 (pin 2's state, KBX §19)
_PIN_2_ACK = bytes.fromhex("60012002")


def _lose_pin_2_acks(twin: KeyboxTwin) -> Callable[[bool], None]:
    """From now on the Keybox applies writes of pin 2 but their acknowledges come back naming
    another object (the driver discards them): its write times out, *uncertain*. Returns the
    switch that puts the acknowledges back."""
    losing = [True]

    def rewrite(reply: bytes) -> bytes:
        if losing[0] and reply.startswith(_PIN_2_ACK):
            return bytes.fromhex("60002002") + reply[4:]  # 2000h/02: no request of ours
        return reply

    twin.filter_sdo_replies(rewrite)
    return lambda on: losing.__setitem__(0, on)


def test_a_cancelled_off_the_keybox_applied_shows_in_actual_once_confirmed(
        bus: tuple[can.BusABC, Emulator, KeyboxTwin], caplog: pytest.LogCaptureFixture) -> None:
    host_bus, emulator, twin = bus

    async def main() -> tuple[str, str, set[asyncio.Task[Any]]]:
        box = AsyncKeybox(host_bus, 0x0C, sdo_timeout=0.2)
        await box.on(2)
        lose = emulator.run(lambda now: _lose_pin_2_acks(twin))
        with pytest.raises(asyncio.TimeoutError):
            await asyncio.wait_for(box.off(2), 0.05)  # the caller gives up
        before = (await box.actual)[2]  # nothing confirmed the OFF yet
        for _ in range(200):  # the worker's retry times out too: nobody hears it but the log
            if _failure_logged(caplog):
                break
            await asyncio.sleep(0.05)
        lose(False)  # the Keybox answers again
        for _ in range(100):  # its state is read back, whoever waits for the off()
            if (await box.actual)[2] == "off":
                break
            await asyncio.sleep(0.05)
        after = (await box.actual)[2]
        for _ in range(100):  # the cancelled call's worker ends: nothing is left waiting
            if asyncio.all_tasks() == {asyncio.current_task()}:
                break
            await asyncio.sleep(0.05)
        left = asyncio.all_tasks() - {asyncio.current_task()}
        await box.__aexit__(None, None, None)
        return before, after, left

    with caplog.at_level("WARNING", logger="blinkcan.host.aio"):
        before, after, left = asyncio.run(main())
    assert _pin(twin, 2) == "off"  # the Keybox applied it
    assert before == "high"  # the state it last showed, never the one asked for
    assert after == "off"  # was "high" until the application called states()
    assert left == set()
    assert _failure_logged(caplog)  # was: the failure vanished


def _failure_logged(caplog: pytest.LogCaptureFixture) -> bool:
    return any("off(2), cancelled by its caller, failed afterwards" in record.getMessage()
               for record in caplog.records)


@pytest.mark.parametrize("command", ["off", "on", "set_outputs", "set_pwm", "reset"])
def test_an_uncertain_output_command_is_read_back(command: str) -> None:
    with Rig() as rig:
        twin = rig.add(KeyboxTwin(node_id=0x0C))
        box = Keybox(rig.bus, 0x0C)
        pin, start, expected = {
            "off": (2, "high", "off"), "on": (2, "off", "high"),
            "set_outputs": (2, "high", "off"), "set_pwm": (12, "off", "high"),
            "reset": (2, "fault", "off")}[command]
        if start == "high":
            box.on(pin)
        elif start == "fault":
            box.on(pin)
            rig.blow_fuse(twin, pin)
            rig.advance(0.5)
        assert box.actual[pin] == start
        ack = bytes((0x60, 0x01, 0x20, pin))  # 2001h/pin
        masks = (bytes.fromhex("60082001"), bytes.fromhex("60082002"))  # 2008h/01, /02
        pwm = bytes.fromhex("60092001")  # 2009h/01 (KBX §22)

        def lose(reply: bytes) -> bytes:  # applied, but the acknowledge never fits
            if reply.startswith((ack, *masks, pwm)):
                return bytes.fromhex("60002001") + reply[4:]
            return reply

        twin.filter_sdo_replies(lose)
        call = {"off": lambda: box.off(pin), "on": lambda: box.on(pin),
                "set_outputs": lambda: box.set_outputs(off=[pin]),
                "set_pwm": lambda: box.set_pwm([pin], 5), "reset": lambda: box.reset(pin)}
        with pytest.raises(SdoTimeoutError) as raised:
            call[command]()
        assert raised.value.uncertain
        assert box.actual[pin] == start  # not confirmed: what the Keybox last showed
        twin.filter_sdo_replies(lambda reply: reply)
        rig.advance(1.0)
        assert box.actual[pin] == expected  # read back: what the Keybox has
        box.close()
