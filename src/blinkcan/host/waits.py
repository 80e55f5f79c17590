"""How long a driver call may wait for a device: one check for every wait a caller names, so
that a bad one is refused before anything is sent (a request sent and then refused could
switch an output while the caller is told it failed)."""

from __future__ import annotations

from typing import Protocol

from blinkcan.protocol.cob import check_time
from blinkcan.runtime.scheduler import LONGEST_VIRTUAL_WAIT

#: the longest a driver call waits for a device (an SDO reply, a J1939 answer): longer is a
#: typo, and 1e300 s overflowed the platform's timers at the first wait
LONGEST_WAIT_S = 24 * 3600.0


class WaitHost(Protocol):
    """What the check needs of the host side of a bus (``host.bus.HostBus``)."""

    @property
    def simulated(self) -> bool: ...


def check_wait(what: str, seconds: float, host: WaitHost | None = None) -> float:
    """``seconds`` if it is a time to wait, 0..:data:`LONGEST_WAIT_S` (on ``host``'s simulated
    bus 0..:data:`LONGEST_VIRTUAL_WAIT` virtual seconds, every simulated wait's bound: a
    longer one would simulate hours of traffic); else TypeError / ValueError naming ``what``
    and the range."""
    check_time(what, seconds, 0)
    simulated = host is not None and host.simulated
    longest = LONGEST_VIRTUAL_WAIT if simulated else LONGEST_WAIT_S
    if seconds > longest:
        unit = "virtual seconds on a simulated bus" if simulated else "seconds"
        raise ValueError(f"{what} must be 0..{longest:g} {unit}, not {seconds!r}")
    return seconds
