"""The asyncio face of the drivers: the same names, as coroutines and async iterators.

``AsyncKeypad(bus, ...)`` takes the arguments of :class:`Keypad`. Blocking calls (SDO) run in
a worker thread; events reach the event loop through ``call_soon_threadsafe``. Callbacks given
to ``on_key`` and the like still run on the bus thread, as with the blocking drivers.
"""

from __future__ import annotations

import asyncio
import functools
from collections.abc import AsyncIterator, Callable
from typing import Any, Generic, TypeVar

from blinkcan.host.device import Device
from blinkcan.host.events import EventSource
from blinkcan.host.keybox import FaultEvent, Keybox
from blinkcan.host.keypad import KeyEvent, Keypad
from blinkcan.host.scan import Found, scan

E = TypeVar("E")
D = TypeVar("D", bound=Device)


def _iterate(source: EventSource[E], timeout: float | None) -> AsyncIterator[E]:
    """Events from the moment of this call on (subscribed now, not at the first ``anext``)."""
    loop = asyncio.get_running_loop()
    waiting: asyncio.Queue[E] = asyncio.Queue()
    remove = source.subscribe(lambda event: loop.call_soon_threadsafe(waiting.put_nowait, event))
    return _drain(waiting, remove, timeout)


async def _drain(waiting: asyncio.Queue[E], remove: Callable[[], None], timeout: float | None
                 ) -> AsyncIterator[E]:
    try:
        while True:
            try:
                yield await asyncio.wait_for(waiting.get(), timeout)
            except asyncio.TimeoutError:
                return
    finally:
        remove()


class _AsyncDevice(Generic[D]):
    """Wraps a blocking driver: its methods become coroutines, its attributes stay readable."""

    def __init__(self, device: D) -> None:
        self.device = device

    def __getattr__(self, name: str) -> Any:
        attribute = getattr(self.device, name)
        if name.startswith("on_") or not callable(attribute):
            return attribute  # callbacks register at once; values are read as they are

        @functools.wraps(attribute)
        async def call(*args: Any, **kwargs: Any) -> Any:
            return await asyncio.to_thread(attribute, *args, **kwargs)

        return call

    def health_events(self, timeout: float | None = None) -> AsyncIterator[Any]:
        return _iterate(self.device.health, timeout)

    async def __aenter__(self) -> Any:
        return self

    async def __aexit__(self, *exc_info: object) -> None:
        self.device.close()


class AsyncKeypad(_AsyncDevice[Keypad]):
    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(Keypad(*args, **kwargs))

    def events(self, timeout: float | None = None) -> AsyncIterator[KeyEvent]:
        return _iterate(self.device.keys, timeout)


class AsyncKeybox(_AsyncDevice[Keybox]):
    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(Keybox(*args, **kwargs))

    def fault_events(self, timeout: float | None = None) -> AsyncIterator[FaultEvent]:
        return _iterate(self.device.faults, timeout)


async def async_scan(*args: Any, **kwargs: Any) -> list[Found]:
    return await asyncio.to_thread(scan, *args, **kwargs)


__all__ = ["AsyncKeybox", "AsyncKeypad", "async_scan"]
