"""Replay byte traces in the manuals' notation against a twin.

A trace is lines: ``> 615 40 00 20 01 …`` sends a frame, ``< 595 4B …`` is the next frame the
device must send in reply (``??`` matches any byte), ``< -`` says it stays silent,
``press 4`` / ``release 4`` act on the keys, ``blow_fuse 4`` / ``replace_fuse 4`` /
``set_input 4 1`` on the Keybox's pins, ``wait 0.5`` advances time, ``on``/``off`` switch
power; any other verb calls the twin's method of that name with its numbers and the time
(``turn 1 -3``, ``set_analog 2 3.0``). Every frame the device sends must be listed.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping

import pytest

from blinkcan.protocol import Frame
from blinkcan.twin.base import CanopenTwin
from blinkcan.twin.registry import build_twin, default_node_id
from tests.conftest import frame


def _matches(pattern: str, actual: Frame) -> bool:
    ident, *data = pattern.split()
    if int(ident, 16) != actual.can_id or len(data) != len(actual.data):
        return False
    return all(p == "??" or int(p, 16) == b for p, b in zip(data, actual.data, strict=False))


class Bench:
    """A twin and a clock."""

    def __init__(self, twin: CanopenTwin, now: float = 0.0) -> None:
        self.twin = twin
        self.now = now
        self.pending: list[Frame] = []

    def replay(self, trace: str) -> None:
        for number, raw in enumerate(trace.strip().splitlines(), start=1):
            line = raw.split("#", 1)[0].strip()
            if not line:
                continue
            verb, _, rest = line.partition(" ")
            if verb == ">":
                self._check_drained(raw)
                self.pending = self.twin.receive(frame(rest), self.now)
            elif verb == "<":
                if rest.strip() == "-":
                    assert self.pending == [], (
                        f"line {number} {raw!r}: expected silence, got {self.pending}")
                    continue
                assert self.pending, f"line {number} {raw!r}: the device sent nothing"
                actual = self.pending.pop(0)
                assert _matches(rest, actual), f"line {number} {raw!r}: the device sent {actual}"
            elif verb in ("press", "release", "blow_fuse", "replace_fuse"):
                self._check_drained(raw)
                self.pending = getattr(self.twin, verb)(int(rest), self.now)
            elif verb == "set_input":
                self._check_drained(raw)
                pin, level = rest.split()
                self.pending = self.twin.set_input(int(pin), level == "1", self.now)  # type: ignore[attr-defined]
            elif verb == "wait":
                self._check_drained(raw)
                self.now += float(rest)
                self.pending = self.twin.advance(self.now)
            elif verb == "on":
                self._check_drained(raw)
                self.pending = self.twin.power_on(self.now)
            elif verb == "off":
                self._check_drained(raw)
                self.twin.power_off()
            elif callable(getattr(self.twin, verb, None)) and not verb.startswith("_"):
                self._check_drained(raw)
                numbers = [float(a) if "." in a else int(a, 0) for a in rest.split()]
                self.pending = getattr(self.twin, verb)(*numbers, self.now)
            else:
                raise ValueError(f"unknown trace line {raw!r}")
        self._check_drained("end of trace")

    def _check_drained(self, where: str) -> None:
        assert not self.pending, f"before {where!r}: unlisted frames {self.pending}"

    def masks(self, prefix: str) -> tuple[int, int, int]:
        """The red, green and blue bit masks of the LED objects ``PREFIX_red`` etc."""
        objects = self.twin.objects
        return (objects.get_int(f"{prefix}_red"), objects.get_int(f"{prefix}_green"),
                objects.get_int(f"{prefix}_blue"))


def replayed(examples: Mapping[str, str], on: str = "bench") -> Callable[..., None]:
    """One test that replays each of a manual's ``examples`` (its section and subject -> its
    trace) on the test module's fixture ``on``: a case per example, named by it, so that every
    manual's traces go through one replay however many models there are."""

    @pytest.mark.parametrize("example", list(examples))
    def test_example(request: pytest.FixtureRequest, example: str) -> None:
        bench = request.getfixturevalue(on)
        assert isinstance(bench, Bench)
        bench.replay(examples[example])

    return test_example


def factory_bench(spec: str) -> tuple[Bench, int]:
    """A twin of ``spec`` ("keybox", "pkp-2600-si@1.5") at its factory settings and default
    node id, powered for 10 s (any startup show over), pre-operational; and that node id."""
    node = default_node_id(spec)
    bench = Bench(build_twin(spec))
    bench.replay(f"on\n< {0x700 + node:X} 00\nwait 10")
    return bench, node
