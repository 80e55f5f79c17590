"""The one clock of every command that prints times (``emulate``, ``monitor``, ``decode``).

Times are seconds since the start: the emulator's start for ``emulate``, the first frame for
``monitor`` and ``decode`` (a bus's or a log's). ``--absolute`` prints wall-clock time instead,
ISO 8601 in UTC (``2026-12-01T21:16:44.123456Z``). A log's own timestamps are never replaced:
``decode --json`` and the Parquet dataset keep each frame's ``time`` as the log recorded it.
"""

from __future__ import annotations

import click

ABSOLUTE = click.option(
    "--absolute", is_flag=True,
    help="Wall-clock times (ISO 8601, UTC) instead of seconds since the start.")


def iso_utc(seconds: float, digits: int = 6) -> str:
    """Seconds since the Unix epoch as ISO 8601 UTC with ``digits`` (3 or 6) decimals."""
    from datetime import datetime, timezone  # noqa: PLC0415 (start-up: only with --absolute)

    spec = "milliseconds" if digits == 3 else "microseconds"
    return datetime.fromtimestamp(seconds, timezone.utc).isoformat(timespec=spec)[:-6] + "Z"


class Clock:
    """Prints a time by the convention: seconds since ``start`` (None: the first time shown),
    or with ``absolute`` the wall clock. ``to_epoch`` is added to a time to make it seconds
    since the epoch (a monotonic clock's offset; 0 for timestamps that already are)."""

    def __init__(self, absolute: bool = False, start: float | None = None,
                 to_epoch: float = 0.0, digits: int = 3) -> None:
        self.absolute = absolute
        self.start = start
        self.to_epoch = to_epoch
        self.digits = digits

    def __call__(self, time: float) -> str:
        if self.absolute:
            return iso_utc(time + self.to_epoch, self.digits)
        if self.start is None:
            self.start = time
        return f"{time - self.start:.{self.digits}f}"
