"""A rig's simulation runs in the thread that made the Rig (DESIGN.md, testing: simulated time
is driven by the test's thread). A blocking driver called from another thread, or an asyncio
loop running in another thread, is refused at once with WrongThreadError saying what to do;
nothing is sent and the clock does not move (session 9's left-alone list: they ran the
simulation from that thread, racing the test's, and the simulated port's send did not check
the thread as ``rig.bus.send`` does)."""

from __future__ import annotations

import asyncio
from collections.abc import Callable
from typing import Any

import pytest

from blinkcan.host import Keypad
from blinkcan.host.aio import AsyncKeypad
from blinkcan.host.bus import HostBus
from blinkcan.testing import Rig, WrongThreadError
from blinkcan.twin.registry import build_twin
from tests.testing.test_rig_threads import _in_thread


def _refused(rig: Rig, call: Callable[[], Any]) -> WrongThreadError:
    """``call()`` in another thread raised WrongThreadError, sent nothing, moved no clock."""
    start, sent = rig.now, len(rig.frames)
    error = _in_thread(call)
    assert isinstance(error, WrongThreadError), error
    text = str(error)
    assert "'reader'" in text, text  # the thread _in_thread makes
    assert "'MainThread'" in text, text
    assert (rig.now, len(rig.frames)) == (start, sent)
    return error


def test_a_blocking_driver_called_from_another_thread_is_refused() -> None:
    with Rig() as rig:
        twin = rig.add(build_twin("keypad"))
        with Keypad(rig.bus) as keypad:
            _refused(rig, lambda: keypad.read("producer_heartbeat_time"))  # an SDO
            _refused(rig, lambda: keypad.set_led(1, "green"))  # a PDO, no wait
            _refused(rig, lambda: list(keypad.events(timeout=1.0)))  # a wait, no send
            _refused(rig, lambda: keypad.host.sleep(1.0))
            # the rig's own thread goes on as if nothing happened
            assert keypad.read("producer_heartbeat_time") == \
                twin.description.table["producer_heartbeat_time"].default


def test_a_driver_made_in_another_thread_is_refused_and_leaves_nothing() -> None:
    with Rig() as rig:
        rig.add(build_twin("keypad"))
        _refused(rig, lambda: Keypad(rig.bus))
        assert rig.bus.frame_listeners() == []
        with Keypad(rig.bus) as keypad:
            keypad.set_led(1, "green")


def test_the_error_says_what_to_do() -> None:
    with Rig() as rig:
        rig.add(build_twin("keypad"))
        text = str(_refused(rig, lambda: Keypad(rig.bus)))
        assert "asyncio.run" in text, text
        assert "thread that made the Rig" in text, text


def test_an_asyncio_loop_in_another_thread_is_refused() -> None:
    with Rig() as rig:
        twin = rig.add(build_twin("keypad"))

        async def made_there() -> None:
            AsyncKeypad(rig.bus)

        _refused(rig, lambda: asyncio.run(made_there()))
        keypad = AsyncKeypad(rig.bus)  # made in the rig's thread, used from another loop

        async def used_there() -> object:
            return await keypad.read("producer_heartbeat_time")

        _refused(rig, lambda: asyncio.run(used_there()))

        async def events_there() -> None:
            async for _ in keypad.events(timeout=1.0):
                pass

        _refused(rig, lambda: asyncio.run(events_there()))
        # a loop in the rig's thread drives it
        assert asyncio.run(used_there()) == \
            twin.description.table["producer_heartbeat_time"].default
        asyncio.run(keypad.close())


@pytest.mark.parametrize("where", ["HostBus", "rig.bus"])
def test_the_rigs_own_thread_and_its_simulation_still_send(where: str) -> None:
    """Frames sent inside the simulation (a handler, a timer, spawned work) are in the rig's
    thread: taken as before."""
    with Rig() as rig:
        rig.add(build_twin("keypad"))
        host = HostBus(rig.bus).start()
        sent = len(rig.frames)
        host.call_later(0.1, lambda: host.send(rig.frames[0].frame))
        rig.advance(0.2)
        assert len(rig.frames) > sent
        host.stop()
