"""The asyncio drivers' event iterators in simulated time (``blinkcan.testing.Rig``).

Waiting for the next event must run the simulation, as the blocking iterators do: nothing else
moves a rig's clock while a test awaits. Before, ``async for event in keypad.events()`` on a
rig waited in real time for ever (the heartbeat that was to be "lost" never was: the clock
stood still), and ``events(timeout=2.0)`` took two real seconds of no virtual time. Every test
here bounds its wall time, so a hang is a failure with a message, not a stuck suite."""

from __future__ import annotations

import asyncio
import sys
import threading
from collections.abc import AsyncIterator, Awaitable, Callable, Iterator
from typing import Any

import pytest

from blinkcan.host import AsyncKeybox, AsyncKeypad, async_scan
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


# -- issue: async calls on a rig ran the simulation in worker threads -----------------------------

#: Keyboxes on the rig of the concurrency tests (node ids): calls to different nodes share no
#: SDO channel, so nothing but the simulation's one thread keeps them apart
BOXES = range(0x0C, 0x12)


def _concurrent_calls(rig: Rig) -> list[object]:
    """60 SDO calls at once from the asyncio faces of :data:`BOXES` (every 7th cancelled before
    it ran), then a scan and the closes: the results (an exception is a result)."""

    async def main() -> list[object]:
        boxes = [AsyncKeybox(rig.bus, node_id) for node_id in BOXES]
        await asyncio.gather(*(box.open() for box in boxes))
        calls = [asyncio.ensure_future(box.on(index % 8 + 1) if index % 2 == 0
                                       else box.state(index % 8 + 1))
                 for index, box in enumerate(boxes[index % len(boxes)] for index in range(60))]
        for call in calls[::7]:
            call.cancel()
        results = await asyncio.gather(*calls, return_exceptions=True)
        found = await async_scan(rig.bus, listen=0.1, timeout=0.05, node_ids=BOXES)
        await asyncio.gather(*(box.__aexit__(None, None, None) for box in boxes))
        return [*results, [item.node_id for item in found]]

    return _bounded(main)  # type: ignore[no-any-return]


def _rig_with_boxes() -> Rig:
    rig = Rig(response_delay=0.002)  # each reply a little late: the waits overlap
    for node_id in BOXES:
        rig.add(KeyboxTwin(node_id=node_id))
    return rig


@pytest.fixture
def often_switching_threads() -> Iterator[None]:
    """Python switches threads as often as it can: a race between threads shows every run."""
    interval = sys.getswitchinterval()
    sys.setswitchinterval(1e-6)
    yield
    sys.setswitchinterval(interval)


def test_async_calls_on_a_rig_put_their_frames_on_the_wire_from_the_rigs_thread() -> None:
    """Every frame the asyncio faces send on a rig is sent by the thread that made the rig
    (the simulation's one thread), whatever the call: opening, a method, a property, an
    iterator's wait, a scan, the close. Before, they came from ``asyncio.to_thread`` workers,
    writing the wire log and the simulation's queue beside the rig's thread."""
    senders: set[str] = set()
    with Rig() as rig:
        twin = rig.add(KeypadTwin(node_id=0x15))
        rig.add(KeyboxTwin(node_id=0x0C))

        def note_sender(frame: object) -> bool:
            senders.add(threading.current_thread().name)
            return False  # drops nothing

        rig.drop(note_sender)

        async def main() -> None:
            keypad = AsyncKeypad(rig.bus, 0x15)
            async with AsyncKeybox(rig.bus, 0x0C) as keybox:
                await keybox.on(3)
                await keypad.set_led(2, "green")
                assert await keypad.generation == "1.1"
                keys = keypad.events(1.0)
                rig.tap(twin, 4)
                assert [event.key async for event in keys] == [4, 4]
                assert [found.node_id for found in await async_scan(
                    rig.bus, listen=0.1, timeout=0.05, node_ids=range(0x0C, 0x16))] == [0x0C, 0x15]
            await keypad.__aexit__(None, None, None)

        _bounded(main)
    assert senders == {threading.current_thread().name}


@pytest.mark.usefixtures("often_switching_threads")
def test_many_concurrent_async_calls_on_a_rig_give_an_ordered_complete_wire_log() -> None:
    """60 concurrent SDO calls to 6 Keyboxes (some cancelled): each is answered, once, in
    order, and the same scenario gives the same wire log and results on every run. Before,
    the calls ran the simulation in several worker threads at once: some failed ("SDO
    transfers block: call them from your thread"; "no device answers"), and the frames
    changed from run to run."""
    logs, outcomes = [], []
    for _ in range(2):
        with _rig_with_boxes() as rig:
            results = _concurrent_calls(rig)
            frames = list(rig.frames)
            states = {node_id: rig.snapshot(node_id)["pins"] for node_id in BOXES}
        logs.append(frames)
        outcomes.append([type(result).__name__ if isinstance(result, BaseException) else result
                         for result in results])
        failures = [result for result in results if isinstance(result, Exception)]
        assert failures == []
        assert results[-1] == list(BOXES)  # the scan found every Keybox
        times = [time for time, _ in frames]
        assert times == sorted(times)
        requests = [frame for _, frame in frames if 0x600 < frame.can_id < 0x680]
        replies = [frame for _, frame in frames if 0x580 < frame.can_id < 0x600]
        assert len(replies) == len(requests)  # every request answered, once
        ran = [index for index, result in enumerate(results[:60])
               if not isinstance(result, BaseException)]
        assert len(ran) == 60 - len(range(0, 60, 7))
        for index in ran:  # every "on" that ran left its pin high
            if index % 2 == 0:
                assert states[BOXES[index % len(BOXES)]][index % 8]["state"] == "high"
            else:
                assert results[index] in ("high", "off")
    assert logs[0] == logs[1]
    assert outcomes[0] == outcomes[1]
