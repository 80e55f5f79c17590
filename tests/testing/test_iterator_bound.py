"""A driver's event iterator with no timeout, on a Rig, ends after :data:`RECV_FOREVER` virtual
seconds with no event: the same bound as ``rig.bus.recv()`` and ``Tester.expect`` with no
timeout (README, Testing). It waited 3600 virtual seconds, so ``list(keypad.events())`` on a
busy rig ran for an hour of traffic (44 s of wall time under load, near the rig fixture's 60 s
limit). Checked for every iterator of every registered model, generation and protocol, on a
busy rig (a heartbeat every 10 ms, the driver watching it)."""

from __future__ import annotations

import inspect
from collections.abc import Callable, Iterator
from typing import Any

import pytest

from blinkcan.host.events import LONGEST_EVENT_WAIT
from blinkcan.host.pkp3500 import AsyncPkp3500Keypad
from blinkcan.host.registry import driver_class
from blinkcan.runtime.virtual_waits import RECV_FOREVER
from blinkcan.testing import Rig
from blinkcan.twin.registry import build_twin
from tests.conformance.cases import CASES, Case


def _iterators(case: Case) -> Iterator[object]:
    """(case, iterator name) for every iterator (``*events``) of the case's driver class;
    the quirk profile changes nothing here: the firmware one."""
    cls = driver_class(case.model.name)
    for name, _ in inspect.getmembers(cls, callable):
        if name.endswith("events") and not name.startswith("_"):
            yield pytest.param(case, name, id=f"{case.spec}-{case.protocol}-{name}")


ITERATORS = [param for case in CASES if case.quirks == "firmware" for param in _iterators(case)]


def _busy_rig(case: Case) -> tuple[Rig, Any]:
    """A rig with the case's twin (a heartbeat every 10 ms in CANopen) and its driver, which
    watches that heartbeat."""
    rig = Rig()
    options: dict[str, Any] = {}
    if case.canopen:
        options["settings"] = {"producer_heartbeat_time": 10}
    else:
        options["protocol"] = case.protocol
    twin = rig.add(build_twin(case.spec, **options))
    cls = driver_class(case.model.name)
    arguments: dict[str, Any] = {}
    parameters = inspect.signature(cls).parameters
    if "model" in parameters:
        arguments["model"] = case.model.name
    if not case.canopen:
        arguments["protocol"] = case.protocol
    driver = cls(rig.bus, twin.node_id, **arguments)
    if case.canopen:
        driver.monitor_heartbeat(0.05)
    rig.advance(0.1)
    return rig, driver


@pytest.mark.parametrize(("case", "name"), ITERATORS)
def test_an_iterator_without_timeout_ends_after_the_bound_with_no_event(case: Case,
                                                                       name: str) -> None:
    rig, driver = _busy_rig(case)
    with rig:
        iterate: Callable[[], Iterator[object]] = getattr(driver, name)
        start = rig.now
        assert list(iterate()) == []
        assert rig.now - start == pytest.approx(RECV_FOREVER)
        driver.close()


def test_each_event_starts_the_bound_again() -> None:
    """The bound is the quiet time: an iterator sees every event, then ends RECV_FOREVER
    virtual seconds after the last one."""
    rig, keypad = _busy_rig(next(case for case in CASES if case.canopen
                                 and case.model.name == "pkp-2600-si"))
    with rig:
        twin = rig.twins[0]
        start = rig.now
        rig.scheduler.call_at(start + 0.5 * RECV_FOREVER, lambda: rig.press(twin, 3))
        rig.scheduler.call_at(start + 1.5 * RECV_FOREVER, lambda: rig.release(twin, 3))
        events = list(keypad.events())
        assert [(event.key, event.action) for event in events] == [(3, "press"), (3, "long press"),
                                                                  (3, "release")]
        assert rig.now - start == pytest.approx(2.5 * RECV_FOREVER)
        keypad.close()


def test_closing_the_driver_ends_the_iterator_at_once() -> None:
    rig, keypad = _busy_rig(next(case for case in CASES if case.canopen
                                 and case.model.name == "pkp-2600-si"))
    with rig:
        start = rig.now
        rig.scheduler.call_at(start + 1.0, keypad.close)
        assert list(keypad.events()) == []
        assert rig.now - start == pytest.approx(1.0)


@pytest.mark.parametrize("timeout", [1e308, LONGEST_EVENT_WAIT * 2, float("nan"), -1.0,
                                     float("inf")])
@pytest.mark.parametrize(("case", "name"), ITERATORS)
def test_an_iterator_refuses_a_timeout_out_of_range_before_it_waits(case: Case, name: str,
                                                                     timeout: float) -> None:
    """A timeout beyond LONGEST_EVENT_WAIT ran the simulation that long
    (``encoder_events(timeout=1e308)`` on a PKP-3500-MT never ended: 80 ms analog PDOs for
    1e308 virtual s); on a real bus ``queue.get`` raised OverflowError at the first wait. Now a
    ValueError naming the range, at the call, with the clock where it was."""
    rig, driver = _busy_rig(case)
    with rig:
        start = rig.now
        with pytest.raises(ValueError, match=r"timeout must be .*0.*3600.*seconds"):
            getattr(driver, name)(timeout=timeout)
        assert rig.now == start
        driver.close()


@pytest.mark.parametrize("name", ["events", "encoder_events", "health_events"])
def test_an_async_iterator_refuses_a_timeout_out_of_range(name: str) -> None:
    """The asyncio face's iterators take the same range (checked at the call)."""
    rig = Rig()
    twin = rig.add(build_twin("pkp-3500-mt"))
    with rig:
        keypad = AsyncPkp3500Keypad(rig.bus, twin.node_id)
        with pytest.raises(ValueError, match=r"timeout must be .*0.*3600.*seconds"):
            getattr(keypad, name)(timeout=1e308)
        keypad.device.close()


def test_the_longest_timeout_is_taken() -> None:
    rig, keypad = _busy_rig(next(case for case in CASES if case.canopen
                                 and case.model.name == "pkp-2600-si"))
    with rig:
        start = rig.now
        rig.scheduler.call_at(start + 1.0, keypad.close)
        assert list(keypad.events(timeout=LONGEST_EVENT_WAIT)) == []
        assert rig.now - start == pytest.approx(1.0)


@pytest.mark.parametrize("timeout", [1e308, LONGEST_EVENT_WAIT * 2])
def test_rig_until_refuses_a_timeout_beyond_the_bound(timeout: float) -> None:
    """``rig.until(never, timeout=1e308)`` on a busy rig ran for ever, as the iterators did."""
    rig, keypad = _busy_rig(next(case for case in CASES if case.canopen
                                 and case.model.name == "pkp-2600-si"))
    with rig:
        start = rig.now
        with pytest.raises(ValueError, match=r"timeout must be from 0 to 3600 virtual seconds"):
            rig.until(lambda: False, timeout=timeout)
        assert rig.now == start
        with pytest.raises(AssertionError, match=r"not met within 1\.5 virtual s"):
            rig.until(lambda: False, timeout=1.5)
        keypad.close()
