"""The asyncio drivers' event iterators in simulated time (``blinkcan.testing.Rig``).

Waiting for the next event must run the simulation, as the blocking iterators do: nothing else
moves a rig's clock while a test awaits. Before, ``async for event in keypad.events()`` on a
rig waited in real time for ever (the heartbeat that was to be "lost" never was: the clock
stood still), and ``events(timeout=2.0)`` took two real seconds of no virtual time. Every test
here bounds its wall time, so a hang is a failure with a message, not a stuck suite."""

from __future__ import annotations

import asyncio
from collections.abc import AsyncIterator, Awaitable, Callable
from typing import Any

import pytest

from blinkcan.host import AsyncKeybox, AsyncKeypad
from blinkcan.host.events import SIMULATED_FOREVER
from blinkcan.host.pkp3500 import AsyncPkp3500Keypad
from blinkcan.testing import Rig
from blinkcan.twin import KeyboxTwin, KeypadTwin

#: real seconds any of these tests may take; the simulated waits take milliseconds
WALL_LIMIT = 30.0

#: every event iterator of the asyncio faces, with the twin its driver needs
ITERATORS: dict[str, tuple[Callable[[], Any], Callable[[Rig], Any],
                           Callable[[Any, float | None], AsyncIterator[Any]]]] = {
    "AsyncKeypad.events": (lambda: KeypadTwin(node_id=0x15),
                           lambda rig: AsyncKeypad(rig.bus, 0x15),
                           lambda driver, timeout: driver.events(timeout)),
    "AsyncKeypad.health_events": (lambda: KeypadTwin(node_id=0x15),
                                  lambda rig: AsyncKeypad(rig.bus, 0x15),
                                  lambda driver, timeout: driver.health_events(timeout)),
    "AsyncKeybox.fault_events": (lambda: KeyboxTwin(node_id=0x0C),
                                 lambda rig: AsyncKeybox(rig.bus, 0x0C),
                                 lambda driver, timeout: driver.fault_events(timeout)),
    "AsyncPkp3500Keypad.encoder_events": (
        lambda: KeypadTwin(node_id=0x15, model="pkp-3500-mt"),
        lambda rig: AsyncPkp3500Keypad(rig.bus, 0x15),
        lambda driver, timeout: driver.encoder_events(timeout)),
}


def _bounded(main: Callable[[], Awaitable[Any]]) -> Any:
    """``main()`` in a fresh event loop, failed (not hung) after :data:`WALL_LIMIT` s."""
    async def bounded() -> Any:
        try:
            return await asyncio.wait_for(main(), WALL_LIMIT)
        except asyncio.TimeoutError:
            pytest.fail(f"still waiting after {WALL_LIMIT} real seconds: the simulated wait "
                        "did not run the simulation")
    return asyncio.run(bounded())


@pytest.mark.parametrize(("timeout", "expected"), [(None, SIMULATED_FOREVER), (2.0, 2.0)],
                         ids=["no timeout: as the blocking iterator waits",
                              "a timeout is virtual seconds"])
@pytest.mark.parametrize("name", ITERATORS)
def test_an_iterator_with_no_event_ends_after_its_timeout_in_virtual_time(
        name: str, timeout: float | None, expected: float) -> None:
    twin, driver, iterate = ITERATORS[name]
    with Rig() as rig:
        rig.add(twin())

        async def main() -> tuple[list[Any], float]:
            opened = await driver(rig).open()
            start = rig.now
            events = [event async for event in iterate(opened, timeout)]
            await opened.__aexit__(None, None, None)
            return events, rig.now - start

        events, waited = _bounded(main)
    assert events == []
    assert waited == pytest.approx(expected)


def test_a_lost_heartbeat_reaches_an_async_for_in_virtual_time() -> None:
    with Rig() as rig:
        twin = rig.add(KeyboxTwin(node_id=0x0C))

        async def main() -> tuple[str, float]:
            async with AsyncKeybox(rig.bus, 0x0C) as keybox:
                await keybox.monitor_heartbeat(0.1)  # "lost" after 0.2 s without one
                rig.stop_heartbeat(twin)
                start = rig.now
                async for event in keybox.health_events():
                    if event.kind == "lost":
                        return event.kind, event.time - start
            return "ended", 0.0

        kind, after = _bounded(main)
    assert kind == "lost"
    assert 0.1 < after <= 0.3


def test_events_come_in_order_as_the_simulation_makes_them() -> None:
    with Rig() as rig:
        twin = rig.add(KeypadTwin(node_id=0x15, model="pkp-3500-mt"))

        async def main() -> list[tuple[int, int]]:
            keypad = await AsyncPkp3500Keypad(rig.bus, 0x15).open()
            turns = keypad.encoder_events(1.0)
            rig.turn(twin, 1, 2)
            rig.turn(twin, 2, -1)
            return [(event.encoder, event.ticks) async for event in turns]

        assert _bounded(main) == [(1, 1), (1, 1), (2, -1)]


def test_a_cancelled_wait_leaves_the_iterator_and_the_driver_working() -> None:
    with Rig() as rig:
        twin = rig.add(KeypadTwin(node_id=0x15))

        async def main() -> str:
            keypad = await AsyncKeypad(rig.bus, 0x15).open()
            keys = keypad.events()
            with pytest.raises(asyncio.TimeoutError):
                await asyncio.wait_for(keys.__anext__(), 0.0)  # the caller gives up at once
            await asyncio.sleep(0.1)  # the abandoned wait's worker stops
            rig.tap(twin, 3)
            await keypad.set_led(3, "green")
            later = keypad.events(1.0)
            rig.tap(twin, 4)
            return " ".join([f"{event.key} {event.action}" async for event in later])

        assert _bounded(main) == "4 press 4 release"


@pytest.mark.parametrize("timeout", [-1.0, float("inf"), float("nan")])
@pytest.mark.parametrize("name", ITERATORS)
def test_an_iterator_timeout_is_checked_when_asked(name: str, timeout: float) -> None:
    """A negative or infinite timeout is a ValueError at the call, blocking or asyncio (it
    was taken: -1 ended the iterator at once, +inf ended it at the simulation's last event)."""
    twin, driver, iterate = ITERATORS[name]
    with Rig() as rig:
        rig.add(twin())

        async def main() -> None:
            opened = await driver(rig).open()
            with pytest.raises(ValueError, match=r"^timeout must be "):
                iterate(opened, timeout)
            with pytest.raises(ValueError, match=r"^timeout must be "):
                iterate(opened.device, timeout)  # the blocking driver's own iterator

        _bounded(main)
