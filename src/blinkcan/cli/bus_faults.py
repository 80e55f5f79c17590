"""Reading a live bus that sometimes fails: a datagram that is not a frame, a driver hiccup.

python-can raises a ``CanError`` from ``recv`` for each of them (udp_multicast: "could not
unpack received message"). A command that watches or records a bus counts them, reports the
first once, and reads on; only a bus that keeps failing, with no frame and no quiet moment in
between for :attr:`BusFaults.give_up_after` seconds, ends the watching.

A datagram python-can *can* unpack is not always a frame: ``udp_multicast`` builds a
``can.Message`` from any msgpack map and checks the ranges of its numbers, not their types, so
``{"arbitration_id": 1.5}`` or a flag ``"yes"`` arrives as a message that every log writer and
the decoder fail on. :func:`receive` counts such a message as one more bus error
(:func:`~blinkcan.formats.frame_check.wrong_type` says why), so one hostile datagram never
ends a recording. Its ranges python-can checked (udp_multicast) or the adapter reported; a
live bus's frame is taken as it comes (a classic DLC of 9-15 included).
"""

from __future__ import annotations

import time
from collections.abc import Callable

import can

from blinkcan.formats.frame_check import wrong_type


class BusFaults:
    """Errors a live bus raised while it was read: how many, the first, and whether the bus
    is failing without a break for so long that reading on is pointless."""

    #: seconds of nothing but errors (no frame, no quiet timeout) before the bus is given up
    give_up_after = 2.0

    def __init__(self) -> None:
        self.count = 0
        self.first: str | None = None
        self._failing_since: float | None = None
        self._last_failure = 0.0

    def failed(self, error: can.CanError, now: float) -> bool:
        """Count one error; True for the first (the one to report)."""
        self.count += 1
        self._last_failure = now
        if self._failing_since is None:
            self._failing_since = now
        if self.first is None:
            cause = f" ({error.__cause__})" if error.__cause__ is not None else ""
            self.first = f"{error or type(error).__name__}{cause}"
            return True
        return False

    def went_on(self) -> None:
        """The bus answered (a frame, or a quiet timeout): it is not failing any more."""
        self._failing_since = None

    def given_up(self) -> bool:
        """The bus has failed on every read for :attr:`give_up_after` seconds."""
        return self._failing_since is not None and \
            self._last_failure - self._failing_since >= self.give_up_after

    def first_text(self) -> str:
        return f"bus error: {self.first}; counted, reading on"

    def summary(self) -> str | None:
        """"3 bus errors (first: ...)", or None when the bus never failed."""
        if not self.count:
            return None
        plural = "s" if self.count != 1 else ""
        return f"{self.count} bus error{plural} while reading (first: {self.first})"

    def give_up_text(self) -> str:
        return (f"the bus kept failing for {self.give_up_after:g} s "
                f"({self.count} errors, first: {self.first}): stopped reading it")


def receive(bus: can.BusABC, timeout: float, faults: BusFaults,
            report: Callable[[str], None]) -> can.Message | None:
    """``bus.recv(timeout)``, with a bus error counted in ``faults`` (the first one passed to
    ``report``) instead of raised; None then, as for a quiet bus. A message that is no frame
    (a field of the wrong type) is such an error too."""
    try:
        message = bus.recv(timeout)
        if message is not None and (why := wrong_type(message)) is not None:
            raise can.CanOperationError(f"received a message that is no CAN frame: {why}")
    except can.CanError as error:
        if faults.failed(error, time.monotonic()):
            report(faults.first_text())
        return None
    faults.went_on()
    return message
