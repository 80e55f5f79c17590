"""Every argument of a driver is checked before the driver attaches to the bus or sends
anything: a bad one raises ValueError/TypeError naming the valid values, and leaves no
attachment behind, so a good driver on the same bus works afterwards (session 9's left-alone
list: ``Device(..., sdo_retries=bad)`` raised after the HostBus was attached, its reader and
subscriptions kept; a bad ``host_node_id`` or J1939 ``address`` of the drivers too)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import pytest

from blinkcan.devices.registry import describe_device
from blinkcan.host import HostBus, Keybox, Keypad
from blinkcan.host.device import Device
from blinkcan.host.pkp3500 import Pkp3500Keypad
from blinkcan.testing import Rig
from blinkcan.twin.registry import build_twin

KEYPAD = describe_device("keypad")

#: (what, the call with the bus, the error) for each bad argument
BAD: list[tuple[str, Callable[[Any], object], type[Exception]]] = [
    ("Device sdo_retries -1", lambda bus: Device(bus, 0x15, KEYPAD, sdo_retries=-1),
     ValueError),
    ("Device sdo_retries 1.5", lambda bus: Device(bus, 0x15, KEYPAD, sdo_retries=1.5),  # type: ignore[arg-type]
     TypeError),
    ("Device sdo_retries '1'", lambda bus: Device(bus, 0x15, KEYPAD, sdo_retries="1"),  # type: ignore[arg-type]
     TypeError),
    ("Device sdo_timeout -1", lambda bus: Device(bus, 0x15, KEYPAD, sdo_timeout=-1),
     ValueError),
    ("Device sdo_timeout 2 h", lambda bus: Device(bus, 0x15, KEYPAD, sdo_timeout=7200.0),
     ValueError),
    ("Device node_id 0", lambda bus: Device(bus, 0, KEYPAD), ValueError),
    ("Device description", lambda bus: Device(bus, 0x15, "keypad"),  # type: ignore[arg-type]
     TypeError),
    ("Device bus", lambda bus: Device("can0", 0x15, KEYPAD),  # type: ignore[arg-type]
     TypeError),
    ("Keypad host_node_id 0x80", lambda bus: Keypad(bus, host_node_id=0x80), ValueError),
    ("Keypad host_node_id '1'", lambda bus: Keypad(bus, host_node_id="1"),  # type: ignore[arg-type]
     TypeError),
    ("Keypad address 0", lambda bus: Keypad(bus, protocol="j1939", address=0), ValueError),
    ("Keypad address 0xFE", lambda bus: Keypad(bus, protocol="j1939", address=0xFE),
     ValueError),
    ("Keypad address '33'", lambda bus: Keypad(bus, protocol="j1939", address="33"),  # type: ignore[arg-type]
     TypeError),
    ("Keypad sdo_timeout nan", lambda bus: Keypad(bus, sdo_timeout=float("nan")),
     ValueError),
    ("Keypad long_press -1", lambda bus: Keypad(bus, long_press=-1), ValueError),
    ("Keypad watchdog 0", lambda bus: Keypad(bus, watchdog=0), ValueError),
    ("Keypad generation 9", lambda bus: Keypad(bus, generation="9"), ValueError),
    ("Keypad model", lambda bus: Keypad(bus, model="keybox"), ValueError),
    ("Keypad protocol", lambda bus: Keypad(bus, protocol="j1708"), ValueError),
    ("Keypad node_id 0x80", lambda bus: Keypad(bus, 0x80), ValueError),
    ("Pkp3500 host_node_id -1", lambda bus: Pkp3500Keypad(bus, host_node_id=-1), ValueError),
    ("Keybox host_node_id 0x80", lambda bus: Keybox(bus, host_node_id=0x80), ValueError),
    ("Keybox fault_poll -1", lambda bus: Keybox(bus, fault_poll=-1), ValueError),
    ("Keybox watchdog 1e9", lambda bus: Keybox(bus, watchdog=1e9), ValueError),
    ("Keybox sdo_timeout '1'", lambda bus: Keybox(bus, sdo_timeout="1"),  # type: ignore[arg-type]
     TypeError),
    ("Keybox node_id 0", lambda bus: Keybox(bus, 0), ValueError),
]


def _subscriptions(host: HostBus) -> int:
    """The handlers subscribed on ``host`` (a driver's left behind)."""
    return sum(map(len, host._handlers.values())) + len(host._extended)


def _attached(rig: Rig) -> int:
    """The handlers a HostBus keeps on the rig's controller bus (a reader left behind)."""
    return len(rig.bus.frame_listeners())


@pytest.mark.parametrize(("what", "make", "error"), BAD, ids=[b[0] for b in BAD])
@pytest.mark.parametrize("given", ["python-can bus", "HostBus"])
def test_a_bad_argument_attaches_nothing_and_sends_nothing(
        what: str, make: Callable[[Any], object], error: type[Exception], given: str) -> None:
    rig = Rig()
    try:
        keypad = rig.add(build_twin("keypad"))
        keybox = rig.add(build_twin("keybox"))
        host = HostBus(rig.bus).start() if given == "HostBus" else None
        bus: Any = host if host is not None else rig.bus
        listeners, sent = _attached(rig), len(rig.frames)
        subscribed = _subscriptions(host) if host is not None else None
        with pytest.raises(error):
            make(bus)
        assert _attached(rig) == listeners
        if host is not None:
            assert _subscriptions(host) == subscribed
            assert host._users == 0
        assert [f for f in rig.frames[sent:] if f.frame.can_id != 0x700 + keypad.node_id
                and f.frame.can_id != 0x700 + keybox.node_id] == []  # heartbeats only
        # a good driver on the same bus works afterwards
        with Keypad(bus) as good:
            good.set_led(1, "green")
            assert good.read("producer_heartbeat_time") == \
                keypad.description.table["producer_heartbeat_time"].default
        if host is not None:
            host.stop()
    finally:
        rig.close()


class _LateCheck(Keypad):
    """A driver class of an application's that refuses an argument of its own after the
    keypad driver set up (attached, confirmed the device)."""

    def __init__(self, bus: Any, colour: str) -> None:
        super().__init__(bus)
        if colour not in ("green", "red"):
            raise ValueError(f"colour must be green or red, not {colour!r}")


def test_a_driver_class_failing_after_the_attach_lets_the_bus_go() -> None:
    rig = Rig()
    try:
        rig.add(build_twin("keypad"))
        with pytest.raises(ValueError, match="colour"):
            _LateCheck(rig.bus, "blue")
        assert _attached(rig) == 0
        with _LateCheck(rig.bus, "green") as good:
            good.set_led(1, "green")
    finally:
        rig.close()
