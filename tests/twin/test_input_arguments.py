"""A twin's physical inputs refuse what no hand or wire does, with ValueError/TypeError naming
what is valid (DESIGN: bad arguments), and take what the manual says the device takes: above
5 V an analog input reads full scale (MT M45), however far above. ``set_analog(0, 1e308)``
was an OverflowError; ``set_digital_input(0, nan)`` (or ``"0"``, ``None``) drove the input
high (found by the attack pass of session 8)."""

from __future__ import annotations

import pytest

from blinkcan.protocol import Frame
from blinkcan.twin import KeypadTwin
from blinkcan.twin.pkp3500 import Pkp3500Twin


def _started() -> Pkp3500Twin:
    twin = KeypadTwin(node_id=0x15, model="pkp-3500-mt")
    assert isinstance(twin, Pkp3500Twin)
    twin.power_on(0.0)
    twin.receive(Frame(0x000, b"\x01\x15"), 0.0)
    return twin


@pytest.mark.parametrize("volts", [12.0, 1e308, 1e20])
def test_any_voltage_above_5_v_reads_full_scale(volts: float) -> None:
    twin = _started()
    assert twin.set_analog(0, volts, 0.1) == []
    assert twin.snapshot()["analog_inputs"] == _full_scale_on_input_0()


def _full_scale_on_input_0() -> object:
    reference = _started()
    reference.set_analog(0, 5.0, 0.1)
    return reference.snapshot()["analog_inputs"]


@pytest.mark.parametrize(("level", "error"), [
    (float("nan"), TypeError), ("1", TypeError), (None, TypeError), (2, ValueError),
    (-1, ValueError), (0.5, TypeError)])
def test_a_digital_level_is_a_bool_or_0_or_1(level: object, error: type[Exception]) -> None:
    twin = _started()
    before = twin.snapshot()
    with pytest.raises(error, match="level"):
        twin.set_digital_input(0, level, 0.1)  # type: ignore[arg-type]
    assert twin.snapshot() == before
    for good in (True, 1, False, 0):
        twin.set_digital_input(0, good, 0.1)  # type: ignore[arg-type]
