"""python-canopen's, cantools' and python-can's own blocking waits, in a simulated bus's
virtual time.

These libraries wait with real-time primitives: python-canopen's SDO client takes its reply
from a ``queue.Queue`` with ``RESPONSE_TIMEOUT`` (0.3 s) and sleeps with ``time.sleep``; its
NMT master and PDO maps wait on a ``threading.Condition``; cantools' ``Tester.expect`` reads a
queue against ``time.time()``. On a simulated bus nothing would ever arrive in that queue while
the caller blocks (the simulation runs only when someone runs it), and the timeouts would take
real seconds. So, while a :class:`~blinkcan.runtime.simbus.SimulatedBus` has adopted a
``can.Notifier`` (which is how these libraries read a bus), exactly these methods are replaced:

- ``canopen.sdo.client.SdoClient.read_response`` and ``send_request`` (reply queue, pauses),
- ``canopen.nmt.NmtMaster.wait_for_heartbeat`` and ``wait_for_bootup``,
- ``canopen.pdo.base.PdoMap.wait_for_reception``,
- ``cantools.tester.Message._expect_input_queue`` (``Tester.expect``; ``timeout=None`` waits at
  most :data:`RECV_FOREVER` virtual seconds, as ``recv()`` does),
- python-can's own ``can.BufferedReader.get_message`` (a reader a notifier on the bus feeds,
  found through python-can's registry of notifiers; ``timeout=None`` as ``recv()``).

Each replacement looks at the bus of the object it is called on: a simulated bus runs its
simulation until the awaited thing happened or the timeout passed in virtual time (the same
result and the same exception as the library's own code, without a wall-clock sleep); any other
bus gets the library's own method, so real time is untouched for everything not on a simulated
bus, also while a rig is open. A method is replaced only if its library is already imported
(a library's notifier on the bus means it is). The replacements are counted per method and put
back when the last bus that installed them shuts down (``Rig.close()``); the count lives on the
replacement itself, because what is patched (a class of another library) is process-wide.

Not replaced (our devices do not use them, or they are not waits on the bus): EMCY
``EmcyConsumer.wait`` (it has no reference to its bus), LSS, CiA 402 profiles, SDO block
upload's retransmission loop, ``TimeProducer``'s wall-clock stamp.
"""

from __future__ import annotations

import logging
import sys
import threading
from collections.abc import Callable
from typing import Any

import can

from blinkcan.runtime.scheduler import (
    LONGEST_VIRTUAL_WAIT,
    SimulatedScheduler,
    check_virtual_timeout,
)

__all__ = ["LONGEST_VIRTUAL_WAIT", "RECV_FOREVER", "check_virtual_timeout",
           "install_virtual_waits"]

#: virtual seconds a wait with no timeout waits at most (``SimulatedBus.recv()`` too)
RECV_FOREVER = 60.0

log = logging.getLogger(__name__)

#: install and undo one at a time, process-wide (they change classes of other libraries)
_PATCHING = threading.Lock()
_ORIGINAL = "_blinkcan_original"
_USERS = "_blinkcan_users"


class _Until:
    """A :class:`~blinkcan.runtime.scheduler.Signal` that is set when ``predicate()`` holds."""

    __slots__ = ("predicate",)

    def __init__(self, predicate: Callable[[], object]) -> None:
        self.predicate = predicate

    def is_set(self) -> bool:
        return bool(self.predicate())

    def set(self) -> None:
        """Nothing to set: the predicate says."""

    def clear(self) -> None:
        """Nothing to clear: the predicate says."""


def _scheduler(bus_of: Callable[[], object]) -> SimulatedScheduler | None:
    """The simulated scheduler of the bus ``bus_of()`` names (a ``SimulatedBus``); None for
    any other bus."""
    try:
        bus = bus_of()
    except (AttributeError, RuntimeError):  # no network yet: the library's own error follows
        return None
    scheduler = getattr(bus, "scheduler", None) if isinstance(bus, can.BusABC) else None
    return scheduler if isinstance(scheduler, SimulatedScheduler) else None


# -- python-can ---------------------------------------------------------------------------------


def _reader_bus(reader: object) -> object:
    """The bus whose running ``can.Notifier`` hands ``reader`` its messages (python-can's
    registry of notifiers and their buses: a reader names no bus); None when none does."""
    registry = getattr(can.Notifier, "_registry", None)
    for pair in list(getattr(registry, "pairs", ())):
        notifier = pair.notifier
        if not notifier.stopped and any(known is reader for known in notifier.listeners):
            return pair.bus
    return None


def _buffered_get_message(original: Callable[..., Any]) -> Callable[..., Any]:
    def get_message(self: Any, timeout: float | None = 0.5) -> Any:
        scheduler = _scheduler(lambda: _reader_bus(self))
        if scheduler is None or self.is_stopped or (timeout is not None and timeout < 0):
            return original(self, timeout)  # python-can's own (a negative timeout: its error)
        wait = RECV_FOREVER if timeout is None else check_virtual_timeout(timeout)
        scheduler.wait(_Until(lambda: not self.buffer.empty()), wait, background=True)
        return original(self, 0)  # a message is buffered, or None: without blocking

    return get_message


# -- python-canopen ---------------------------------------------------------------------------


def _sdo_read_response(original: Callable[..., Any]) -> Callable[..., Any]:
    def read_response(self: Any) -> Any:
        scheduler = _scheduler(lambda: self.network.bus)
        if scheduler is None:
            return original(self)
        scheduler.wait(_Until(lambda: not self.responses.empty()), self.RESPONSE_TIMEOUT)
        if self.responses.empty():
            from canopen.sdo.exceptions import SdoCommunicationError  # noqa: PLC0415
            raise SdoCommunicationError("No SDO response received")
        return original(self)  # a reply is queued: the library reads it without blocking

    return read_response


def _sdo_send_request(original: Callable[..., Any]) -> Callable[..., Any]:
    def send_request(self: Any, request: Any) -> None:
        scheduler = _scheduler(lambda: self.network.bus)
        if scheduler is None:
            original(self, request)
            return
        retries_left = self.MAX_RETRIES
        if self.PAUSE_BEFORE_SEND:
            scheduler.sleep(self.PAUSE_BEFORE_SEND)
        while True:
            try:
                self.network.send_message(self.rx_cobid, request)
            except can.CanError as error:  # as the library does: retry after RETRY_DELAY
                retries_left -= 1
                if not retries_left:
                    raise
                log.info("%s", error)
                if self.RETRY_DELAY:
                    scheduler.sleep(self.RETRY_DELAY)
            else:
                return

    return send_request


def _nmt_wait_for_heartbeat(original: Callable[..., Any]) -> Callable[..., Any]:
    def wait_for_heartbeat(self: Any, timeout: float = 10) -> Any:
        scheduler = _scheduler(lambda: self.network.bus)
        if scheduler is None:
            return original(self, timeout)
        check_virtual_timeout(timeout)
        self._state_received = None
        scheduler.wait(_Until(lambda: self._state_received is not None), timeout,
                       background=True)
        if self._state_received is None:
            from canopen.nmt import NmtError  # noqa: PLC0415
            raise NmtError("No boot-up or heartbeat received")
        return self.state

    return wait_for_heartbeat


def _nmt_wait_for_bootup(original: Callable[..., Any]) -> Callable[..., Any]:
    def wait_for_bootup(self: Any, timeout: float = 10) -> None:
        scheduler = _scheduler(lambda: self.network.bus)
        if scheduler is None:
            original(self, timeout)
            return
        check_virtual_timeout(timeout)
        booted = _Flag()

        def heard(state: int) -> None:
            if state == 0:
                booted.value = True

        self._callbacks.append(heard)
        try:
            scheduler.wait(_Until(lambda: booted.value), timeout, background=True)
        finally:
            self._callbacks.remove(heard)
        if not booted.value:
            from canopen.nmt import NmtError  # noqa: PLC0415
            raise NmtError("Timeout waiting for boot-up message")

    return wait_for_bootup


class _Flag:
    __slots__ = ("value",)

    def __init__(self) -> None:
        self.value = False


def _pdo_wait_for_reception(original: Callable[..., Any]) -> Callable[..., Any]:
    def wait_for_reception(self: Any, timeout: float = 10) -> Any:
        scheduler = _scheduler(lambda: self.pdo_node.network.bus)
        if scheduler is None:
            return original(self, timeout)
        check_virtual_timeout(timeout)
        self.is_received = False
        scheduler.wait(_Until(lambda: self.is_received), timeout, background=True)
        return self.timestamp if self.is_received else None

    return wait_for_reception


# -- cantools ---------------------------------------------------------------------------------


def _tester_expect(original: Callable[..., Any]) -> Callable[..., Any]:
    def _expect_input_queue(self: Any, signals: Any, timeout: float | None,
                            discard_other_messages: bool) -> Any:
        scheduler = _scheduler(lambda: self._can_bus)
        if scheduler is None:
            return original(self, signals, timeout, discard_other_messages)
        end = scheduler.clock() + (RECV_FOREVER if timeout is None else
                                   check_virtual_timeout(timeout))
        arrived = _Until(lambda: not self._input_queue.empty())
        while True:
            if not scheduler.wait(arrived, max(0.0, end - scheduler.clock()), background=True):
                return None
            message = self._input_queue.get_nowait()
            decoded = self._filter_expected_message(message, signals)
            if decoded is not None:
                return decoded
            if not discard_other_messages:
                self._input_list.append(message)
            if scheduler.clock() >= end:
                return None

    return _expect_input_queue


#: (module, class, method, the replacement made from the original)
WAITS: tuple[tuple[str, str, str, Callable[[Callable[..., Any]], Callable[..., Any]]], ...] = (
    ("can.listener", "BufferedReader", "get_message", _buffered_get_message),
    ("canopen.sdo.client", "SdoClient", "read_response", _sdo_read_response),
    ("canopen.sdo.client", "SdoClient", "send_request", _sdo_send_request),
    ("canopen.nmt", "NmtMaster", "wait_for_heartbeat", _nmt_wait_for_heartbeat),
    ("canopen.nmt", "NmtMaster", "wait_for_bootup", _nmt_wait_for_bootup),
    ("canopen.pdo.base", "PdoMap", "wait_for_reception", _pdo_wait_for_reception),
    ("cantools.tester", "Message", "_expect_input_queue", _tester_expect),
)


def install_virtual_waits() -> Callable[[], None]:
    """Replace the waits of the libraries imported now (see the module docstring); returns
    the function that undoes this installation (once; the last one out restores them)."""
    installed: list[tuple[type, str]] = []
    with _PATCHING:
        for module_name, class_name, method, replacement in WAITS:
            module = sys.modules.get(module_name)
            owner = getattr(module, class_name, None) if module is not None else None
            if not isinstance(owner, type) or method not in vars(owner):
                continue
            current = vars(owner)[method]
            if getattr(current, _ORIGINAL, None) is not None:
                setattr(current, _USERS, getattr(current, _USERS) + 1)
            else:
                patched = replacement(current)
                patched.__name__ = getattr(current, "__name__", method)
                patched.__doc__ = getattr(current, "__doc__", None)
                setattr(patched, _ORIGINAL, current)
                setattr(patched, _USERS, 1)
                setattr(owner, method, patched)
            installed.append((owner, method))

    def undo() -> None:
        with _PATCHING:
            while installed:
                owner, method = installed.pop()
                current = vars(owner).get(method)
                original = getattr(current, _ORIGINAL, None)
                if original is None:
                    continue  # replaced by someone else since: theirs now
                users = getattr(current, _USERS) - 1
                setattr(current, _USERS, users)
                if users == 0:
                    setattr(owner, method, original)

    return undo


def installed_waits() -> list[str]:
    """``module.Class.method`` of every wait replaced now (for tests and diagnostics)."""
    found = []
    for module_name, class_name, method, _ in WAITS:
        module = sys.modules.get(module_name)
        owner = getattr(module, class_name, None) if module is not None else None
        if isinstance(owner, type) and getattr(vars(owner).get(method), _ORIGINAL, None):
            found.append(f"{module_name}.{class_name}.{method}")
    return found
