"""A whole number on the command line (jobs, rows, a bit rate, a process id): in a range, checked
before anything opens; text that is no whole number, or one outside, is a usage error naming
the option and the range. :class:`NegativeArguments`: a command whose arguments may be written
negative (``keybox on -1`` is a pin out of range, not an unknown option)."""

from __future__ import annotations

import re
from collections.abc import Sequence
from typing import Any

import click


class Whole(click.ParamType):  # type: ignore[type-arg]
    """``4``: a whole number in ``low``..``high`` (``unit`` follows the range in messages)."""

    name = "integer"

    def __init__(self, low: int, high: int, unit: str = "") -> None:
        self.low = low
        self.high = high
        self.unit = unit

    @property
    def valid(self) -> str:
        """"1..256", "1..1000000 bit/s"."""
        return f"{self.low}..{self.high}" + (f" {self.unit}" if self.unit else "")

    def convert(self, value: Any, param: click.Parameter | None,
                ctx: click.Context | None) -> int:
        if isinstance(value, int) and not isinstance(value, bool):
            number = value
        else:
            try:
                number = int(str(value).strip(), 10)
            except ValueError:
                self.fail(f"{value!r} is not a whole number ({self.valid})", param, ctx)
        if not self.low <= number <= self.high:
            self.fail(f"{value} is outside {self.valid}", param, ctx)
        return number


#: a negative number as a word of its own: "-1", "-0.5", "-.5", "-1e3"
_NEGATIVE = re.compile(r"-\.?\d[\w.+-]*")


class NegativeArguments(click.Command):
    """A command whose arguments may be negative numbers: ``keybox on -1`` is the argument
    -1 (refused then, naming the valid range), not an unknown option "-1"."""

    def parse_args(self, ctx: click.Context, args: list[str]) -> list[str]:
        return super().parse_args(ctx, numbers_as_arguments(self.get_params(ctx), args))


def numbers_as_arguments(params: Sequence[click.Parameter], args: Sequence[str]) -> list[str]:
    """``args`` with the options (and their values) first and the arguments after ``--`` when
    an argument is a negative number; unchanged otherwise."""
    takes_value = {name: not (param.is_flag or param.count)
                   for param in params if isinstance(param, click.Option)
                   for name in (*param.opts, *param.secondary_opts)}
    options: list[str] = []
    arguments: list[str] = []
    negative = False
    index = 0
    while index < len(args):
        word = args[index]
        index += 1
        if word == "--":
            arguments += args[index:]
            break
        name = word.split("=", 1)[0]
        if name in takes_value:
            options.append(word)
            if takes_value[name] and "=" not in word and index < len(args):
                options.append(args[index])  # the option's value, whatever it looks like
                index += 1
        elif _NEGATIVE.fullmatch(word):
            arguments.append(word)
            negative = True
        elif word.startswith("-") and word != "-":
            options.append(word)  # an unknown option: click names it
        else:
            arguments.append(word)
    return [*options, "--", *arguments] if negative else list(args)
