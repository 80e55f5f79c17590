"""A number of seconds on the command line: finite, between a minimum and a maximum (DESIGN:
non-finite times are bad arguments; a time no timer can reach is one too), checked before the
bus opens."""

from __future__ import annotations

import math
from typing import Any

import click

#: the longest time any option takes unless it names its own maximum: a year (a recording,
#: a monitor); beyond it a duration is a typo, and 1e300 s overflows the timers
A_YEAR = 366 * 24 * 3600.0


class Seconds(click.ParamType):  # type: ignore[type-arg]
    """``0.5``, ``2``: a finite number of seconds in ``minimum``..``maximum``; ``nan``,
    ``inf``, numbers too large for a float and numbers outside are a usage error naming the
    option and the range."""

    name = "seconds"

    def __init__(self, minimum: float = 0.0, maximum: float = A_YEAR,
                 unit: str = "seconds") -> None:
        self.minimum = minimum
        self.maximum = maximum
        self.unit = unit

    @property
    def valid(self) -> str:
        """"0..10 seconds"."""
        return f"{self.minimum:.10g}..{self.maximum:.10g} {self.unit}"

    def convert(self, value: Any, param: click.Parameter | None,
                ctx: click.Context | None) -> float:
        try:
            number = float(value)
        except (TypeError, ValueError):
            self.fail(f"{value!r} is not a number of {self.unit} ({self.valid})", param, ctx)
        if not math.isfinite(number):
            self.fail(f"{value} is not a finite number of {self.unit} ({self.valid})", param,
                      ctx)
        if not self.minimum <= number <= self.maximum:
            self.fail(f"{value} is outside {self.valid}", param, ctx)
        return number


class Factor(Seconds):
    """``2``, ``0.5``: a finite factor (a replay's speed) in ``minimum``..``maximum``."""

    name = "factor"

    def __init__(self, minimum: float = 0.0, maximum: float = 1e6) -> None:
        super().__init__(minimum, maximum, unit="times the pace")
