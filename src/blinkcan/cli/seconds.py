"""A number of seconds on the command line: finite and at least a minimum (DESIGN: non-finite
times are bad arguments), checked before the bus opens."""

from __future__ import annotations

import math
from typing import Any

import click


class Seconds(click.ParamType):  # type: ignore[type-arg]
    """``0.5``, ``2``: a finite number of seconds, at least ``minimum``; ``nan``, ``inf`` and
    numbers too large for a float are a usage error naming the option."""

    name = "seconds"

    def __init__(self, minimum: float = 0.0, unit: str = "seconds") -> None:
        self.minimum = minimum
        self.unit = unit

    def convert(self, value: Any, param: click.Parameter | None,
                ctx: click.Context | None) -> float:
        try:
            number = float(value)
        except (TypeError, ValueError):
            self.fail(f"{value!r} is not a number of {self.unit}", param, ctx)
        if not math.isfinite(number):
            self.fail(f"{value} is not a finite number of {self.unit}", param, ctx)
        if number < self.minimum:
            self.fail(f"{value} is less than {self.minimum:g} {self.unit}", param, ctx)
        return number


class Factor(Seconds):
    """``2``, ``0.5``: a finite factor (a replay's speed), at least ``minimum``."""

    name = "factor"

    def __init__(self, minimum: float = 0.0) -> None:
        super().__init__(minimum, unit="times the pace")
