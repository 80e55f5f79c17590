"""A driver's wait on a simulated bus takes at most LONGEST_VIRTUAL_WAIT (an hour of virtual
time), as every other wait on a rig does (``rig.until``, the event iterators, ``rig.bus.recv``,
python-canopen's and cantools' waits). The drivers take timeouts up to a day (a real bus); on a
busy rig a day with no reply was minutes of wall time (a Keybox with a 10 ms heartbeat: 1.3 s
of wall time per 1,000 virtual s), so a ``sdo_timeout`` of a day to an absent device held a
test for about four minutes before it failed (last session's noticed list). Now a ValueError
naming the bound, before the simulation runs: the clock has not moved."""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from functools import partial
from typing import Any

import pytest

from blinkcan.host import Keybox, Keypad
from blinkcan.runtime.scheduler import SimulatedScheduler
from blinkcan.runtime.virtual_waits import LONGEST_VIRTUAL_WAIT
from blinkcan.testing import Rig
from blinkcan.twin import KeyboxTwin

#: over the bound, and still under the drivers' own bound of a day
TOO_LONG = 1.5 * LONGEST_VIRTUAL_WAIT
BOUND = r"^timeout must be at most 3600 virtual seconds on a simulated bus"
#: a driver's own wait, checked before anything is sent
DRIVER_BOUND = r"^(sdo_timeout|timeout) must be 0\.\.3600 virtual seconds on a simulated bus"


@pytest.fixture
def busy() -> Iterator[Rig]:
    """A rig with traffic (a Keybox's 10 ms heartbeat) and no device at 0Dh or 15h."""
    with Rig() as rig:
        rig.add(KeyboxTwin(node_id=0x0C, settings={"producer_heartbeat_time": 10}))
        rig.advance(0.05)
        yield rig


#: driver waits that reach no device on the busy rig, made ready to call (a driver used by the
#: call is opened first: its own requests are not the call's)
WAITS: dict[str, Callable[[Rig], Callable[[], Any]]] = {
    "Keybox opening (SDO)": lambda rig: partial(Keybox, rig.bus, 0x0D, sdo_timeout=TOO_LONG),
    "Keypad opening (SDO)": lambda rig: partial(Keypad, rig.bus, 0x15, sdo_timeout=TOO_LONG),
    "J1939 keypad opening": lambda rig: partial(Keypad, rig.bus, protocol="j1939",
                                                sdo_timeout=TOO_LONG),
    "an SDO upload's own timeout": lambda rig: partial(
        Keybox(rig.bus, 0x0C).sdo.upload, 0x1000, 0, timeout=TOO_LONG),
    "an SDO download's own timeout": lambda rig: partial(
        Keybox(rig.bus, 0x0C).sdo.download, 0x2001, 4, b"\x01", timeout=TOO_LONG),
}


@pytest.mark.parametrize("wait", WAITS)
def test_a_driver_wait_over_the_bound_is_refused_before_the_simulation_runs(
        busy: Rig, wait: str) -> None:
    call = WAITS[wait](busy)
    start, sent = busy.now, len(busy.frames)
    with pytest.raises(ValueError, match=DRIVER_BOUND):
        call()
    assert busy.now == start  # no virtual time ran: no wall time either
    busy.advance(1.0)  # a request queued before the refusal would go out now
    requests = [f for f in list(busy.frames)[sent:] if f.frame.can_id != 0x70C]
    assert requests == []  # refused before anything was sent: nothing switched meanwhile


@pytest.mark.parametrize("timeout", [TOO_LONG, math.inf, math.nan, -math.inf])
def test_the_simulated_scheduler_refuses_a_wait_over_the_bound(timeout: float) -> None:
    scheduler = SimulatedScheduler()
    for background in (False, True):
        with pytest.raises(ValueError, match=BOUND if not timeout < 0
                           else r"^timeout must be a finite number"):
            scheduler.wait(scheduler.signal(), timeout, background)
    assert scheduler.now == 0.0


def test_a_wait_of_the_bound_itself_is_taken() -> None:
    scheduler = SimulatedScheduler()
    assert not scheduler.wait(scheduler.signal(), LONGEST_VIRTUAL_WAIT)
    assert scheduler.now == LONGEST_VIRTUAL_WAIT
