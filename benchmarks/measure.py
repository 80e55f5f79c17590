"""Shared by the benchmarks: interleaved repetitions, CPU of a child process, medians with
ranges. The machine is shared (2 cores, several users): CPU seconds of the process that does
the work are steadier than wall time, and ours and the anchor's alternate so both see the same
load."""

from __future__ import annotations

import os
import resource
import statistics
import subprocess
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TypeVar

T = TypeVar("T")


def child_cpu(arguments: Sequence[str], stdin: Path | None = None) -> float:
    """CPU seconds (user + system) of one child process run to its end, output discarded."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    with open(os.devnull, "w") as sink:
        if stdin is None:
            subprocess.run(arguments, stdout=sink, check=True)
        else:
            with stdin.open("rb") as source:
                subprocess.run(arguments, stdin=source, stdout=sink, check=True)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def interleaved(runs: dict[str, Callable[[], T]], repeats: int) -> dict[str, list[T]]:
    """Each run ``repeats`` times, alternating: ours, anchor, ours, anchor, ..."""
    results: dict[str, list[T]] = {name: [] for name in runs}
    for _ in range(repeats):
        for name, run in runs.items():
            results[name].append(run())
    return results


def spread(values: Sequence[float], scale: float = 1.0, form: str = ",.0f") -> str:
    """"median (min-max)" of values times ``scale``."""
    scaled = sorted(v * scale for v in values)
    if len(scaled) == 1:
        return format(scaled[0], form)
    return (f"{format(statistics.median(scaled), form)} "
            f"({format(scaled[0], form)}-{format(scaled[-1], form)})")


def ratios(ours: Sequence[float], anchor: Sequence[float]) -> list[float]:
    """Per repetition, how many times faster ours is (the anchor's time over ours)."""
    return [a / o for o, a in zip(ours, anchor, strict=True)]


def ratio_text(ours: Sequence[float], anchor: Sequence[float]) -> str:
    return f"{spread(ratios(ours, anchor), form='.2f')}x"
