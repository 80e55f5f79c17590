"""What a ``keypad`` / ``keybox`` command's arguments may be, read from the model descriptions.

Arguments are checked before the bus is touched, against every model that may answer: the one
``--model`` names, else every registered model of that kind (each generation), so ``keybox on
14`` says ``pin 14 outside 1..13`` and never ``no device answers``. Once the device is found,
the same check runs against its own description before any command is sent (a PKP-2600-SI has
LEDs on keys 1..12, a PKP-3500-MT on 2..10 and 12..15).

A check is a function of the descriptions that raises ValueError naming the valid values.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence

from blinkcan.devices.model import DeviceDescription
from blinkcan.devices.registry import models, parse_spec

Spans = tuple[tuple[int, int], ...]
Check = Callable[[Sequence[DeviceDescription]], None]


def candidates(kind: str, spec: str | None = None, feature: str | None = None
               ) -> tuple[DeviceDescription, ...]:
    """The descriptions that may answer: ``spec``'s model (every generation unless it names
    one), else every registered model of ``kind``; only those with ``feature`` when given.
    ValueError for a spec of another kind."""
    if spec is not None:
        found, generation = parse_spec(spec)
        if found.kind != kind:
            names = ", ".join(m.name for m in models() if m.kind == kind)
            raise ValueError(f"{found.name} is not a {kind}; {kind} models: {names}")
        generations = [generation] if "@" in spec else list(found.generations)
        chosen = [found.description(g) for g in generations]
    else:
        chosen = [m.description(g) for m in models() if m.kind == kind for g in m.generations]
    if feature is not None:
        chosen = [d for d in chosen if feature in d.features]
    return tuple(chosen)


def spans_of(values: Iterable[int]) -> Spans:
    """Sorted values as inclusive runs: 1, 2, 3, 5 -> ((1, 3), (5, 5))."""
    runs: list[list[int]] = []
    for value in sorted(set(values)):
        if runs and value == runs[-1][1] + 1:
            runs[-1][1] = value
        else:
            runs.append([value, value])
    return tuple((low, high) for low, high in runs)


def merged(all_spans: Iterable[Spans]) -> Spans:
    """The union of several span sets, as runs."""
    runs: list[list[int]] = []
    for low, high in sorted(span for spans in all_spans for span in spans):
        if runs and low <= runs[-1][1] + 1:
            runs[-1][1] = max(runs[-1][1], high)
        else:
            runs.append([low, high])
    return tuple((low, high) for low, high in runs)


def describe(spans: Spans) -> str:
    """"1..12", "0, 10..65279", "2..10, 12..15"."""
    return ", ".join(f"{low}" if low == high else f"{low}..{high}" for low, high in spans)


def within(what: str, value: int, spans: Spans) -> None:
    """ValueError "pin 14 outside 1..13" unless ``value`` is in ``spans``."""
    if not any(low <= value <= high for low, high in spans):
        raise ValueError(f"{what} {value} outside {describe(spans)}")


def entry_spans(descriptions: Sequence[DeviceDescription], name: str) -> Spans:
    """The values the object entry ``name`` takes, over ``descriptions`` that have it."""
    found = []
    for description in descriptions:
        if name in description.table:
            valid = description.table[name].valid
            if valid is not None:
                found.append(valid.spans)
    return merged(found)


def whose(descriptions: Sequence[DeviceDescription]) -> str:
    """"the PKP-2600-SI keypad", or "any registered keypad" for several models."""
    titles = {d.title for d in descriptions}
    if len(titles) == 1:
        return f"the {titles.pop()}"
    return f"any registered {descriptions[0].kind}" if descriptions else "no registered model"
