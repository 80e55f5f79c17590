"""The key PDO's tick timer is an 8-bit counter of 100 ms steps since power-on that wraps (PKP
rev 1.5 §11 note, errata P8): a twin given any finite time sends a tick, an absurd time too.
``KeypadTwin().press(3, 1e308)`` was an OverflowError in the tick's arithmetic (found by the
attack pass of session 8); a time that is no number of seconds (inf, nan) is refused with a
ValueError naming what is valid."""

from __future__ import annotations

import sys

import pytest

from blinkcan.devices.pdo import PdoLayout
from blinkcan.devices.registry import models
from blinkcan.protocol import Frame
from blinkcan.twin import KeypadTwin
from blinkcan.twin.base import CanopenTwin
from blinkcan.twin.registry import build_twin

#: every model generation whose description has a PDO with a tick timer, and that PDO
TICKED = [(f"{model.name}@{generation}", layout.name)
          for model in models() for generation in model.generations
          for layout in model.description(generation).pdos
          if any(signal.name == "tick" for signal in layout.signals)]
ABSURD = [1e308, sys.float_info.max, -sys.float_info.max, 1e300, 2.0 ** 70]


def _started(spec: str) -> KeypadTwin:
    twin = build_twin(spec)
    assert isinstance(twin, KeypadTwin)  # a twin with keys to press
    twin.power_on(0.0)
    twin.receive(Frame(0x000, bytes((0x01, twin.node_id))), 0.0)  # NMT start (CiA 301)
    return twin


def _tick(twin: CanopenTwin, layout: PdoLayout, frames: list[Frame]) -> int:
    sent = [frame for frame in frames if frame.can_id == layout.cob_id(twin.node_id)]
    assert len(sent) == 1, frames
    return layout.decode(sent[0].data)["tick"]


def test_some_model_has_a_tick() -> None:
    assert TICKED  # else the tests below test nothing


@pytest.mark.parametrize(("spec", "pdo"), TICKED)
@pytest.mark.parametrize("now", ABSURD)
def test_a_key_pressed_at_an_absurd_time_sends_a_tick(spec: str, pdo: str, now: float) -> None:
    twin = _started(spec)
    layout = twin.description.pdo(pdo)
    tick = _tick(twin, layout, twin.press(1, now))
    assert 0 <= tick <= 0xFF
    assert _tick(twin, layout, twin.release(1, now)) == tick  # the same time, the same tick


@pytest.mark.parametrize(("spec", "pdo"), TICKED)
def test_the_tick_counts_100_ms_steps_and_wraps_at_256(spec: str, pdo: str) -> None:
    twin = _started(spec)
    layout = twin.description.pdo(pdo)
    assert _tick(twin, layout, twin.press(1, 0.25)) == 2
    assert _tick(twin, layout, twin.release(1, 25.65)) == 0  # 256 steps: wrapped
    assert _tick(twin, layout, twin.press(1, 25.75)) == 1


@pytest.mark.parametrize(("spec", "pdo"), TICKED)
@pytest.mark.parametrize("now", [float("inf"), float("-inf"), float("nan")])
def test_a_time_that_is_no_number_of_seconds_is_refused(spec: str, pdo: str, now: float
                                                        ) -> None:
    twin = _started(spec)
    with pytest.raises(ValueError, match="now must be a finite number of seconds"):
        twin.press(1, now)
