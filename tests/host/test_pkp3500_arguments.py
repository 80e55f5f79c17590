"""Every public setter of the PKP-3500-MT driver refuses an argument of the wrong type (a
text, a float, a bool, None where an int or a list of ints is expected) with a TypeError
naming the type expected: ``set_ring(1, "123")`` was a ValueError ("ring 1 has LEDs 1..16,
not ['1', '2', '3']"), ``set_top(1, "3")`` a ValueError, ``set_ring(1, [True])`` lit LED 1,
``set_ring(1, 5)`` Python's "'int' object is not iterable"."""

from __future__ import annotations

from collections.abc import Callable, Iterator

import pytest

from blinkcan.host import Keypad
from blinkcan.host.pkp3500 import Pkp3500Keypad
from blinkcan.testing import Rig
from blinkcan.twin import KeypadTwin

MT = "pkp-3500-mt"
WRONG = ["3", "123", 1.0, True, None]
#: the twin's objects the setters write
WRITTEN = ("encoder_1_top", "encoder_1_ticks", "tpdo2_event_timer", "led_on_rings",
           "led_blink_rings", "analog_period", "indicator_brightness")

#: each setter with the one argument under test, and the words its TypeError names
CALLS: dict[str, tuple[Callable[[Pkp3500Keypad, object], object], str]] = {
    "set_top encoder": (lambda k, v: k.set_top(v, 3), "encoder must be an int"),  # type: ignore[arg-type]
    "set_top top": (lambda k, v: k.set_top(1, v), "top must be an int"),  # type: ignore[arg-type]
    "set_startup_counter": (lambda k, v: k.set_startup_counter(1, v),  # type: ignore[arg-type]
                            "startup counter must be an int"),
    "read_counter": (lambda k, v: k.read_counter(v), "encoder must be an int"),  # type: ignore[arg-type]
    "set_encoder_period": (lambda k, v: k.set_encoder_period(1, v),  # type: ignore[arg-type]
                           "must be a number of seconds"),
    "set_ring encoder": (lambda k, v: k.set_ring(v, [1]), "encoder must be an int"),  # type: ignore[arg-type]
    "set_ring leds": (lambda k, v: k.set_ring(1, v),  # type: ignore[arg-type]
                      r"leds must be an iterable of LED numbers \(ints\)"),
    "set_ring led": (lambda k, v: k.set_ring(1, [1, v]), "ring LED must be an int"),  # type: ignore[list-item]
    "ring": (lambda k, v: k.ring(v), "encoder must be an int"),  # type: ignore[arg-type]
    "set_ring_blink leds": (lambda k, v: k.set_ring_blink(v),  # type: ignore[arg-type]
                            r"leds must be an iterable of LED numbers \(ints\)"),
    "set_ring_blink led": (lambda k, v: k.set_ring_blink([v]), "ring LED must be an int"),  # type: ignore[list-item]
    "read_analog": (lambda k, v: k.read_analog(v), "input must be an int"),  # type: ignore[arg-type]
    "set_analog_period": (lambda k, v: k.set_analog_period(v),  # type: ignore[arg-type]
                          "must be a number of seconds"),
    "set_brightness": (lambda k, v: k.set_brightness(v), "brightness must be an int"),  # type: ignore[arg-type]
}


@pytest.fixture(scope="module")
def driven() -> Iterator[tuple[Rig, KeypadTwin, Pkp3500Keypad]]:
    with Rig() as rig:
        twin = rig.add(KeypadTwin(node_id=0x15, model=MT))
        keypad = Keypad(rig.bus, 0x15, model=MT)
        assert isinstance(keypad, Pkp3500Keypad)
        rig.settle()
        yield rig, twin, keypad


@pytest.mark.parametrize("wrong", WRONG, ids=repr)
@pytest.mark.parametrize("call", list(CALLS))
def test_a_wrong_type_is_a_type_error_naming_the_type_expected(
        driven: tuple[Rig, KeypadTwin, Pkp3500Keypad], call: str, wrong: object) -> None:
    rig, twin, keypad = driven
    if call.endswith("period") and isinstance(wrong, float):
        return  # a float is a period
    before = [twin.objects[name] for name in WRITTEN]
    setter, expected = CALLS[call]
    with pytest.raises(TypeError, match=f"{expected}|must be a number of seconds, not"):
        setter(keypad, wrong)
    rig.settle()
    assert [twin.objects[name] for name in WRITTEN] == before  # nothing was written


@pytest.mark.parametrize("call", list(CALLS))
def test_the_type_error_names_what_was_given(
        driven: tuple[Rig, KeypadTwin, Pkp3500Keypad], call: str) -> None:
    setter, expected = CALLS[call]
    with pytest.raises(TypeError, match=f"{expected}.*, not str"):
        setter(driven[2], "123")


def test_right_types_still_work(driven: tuple[Rig, KeypadTwin, Pkp3500Keypad]) -> None:
    rig, twin, keypad = driven
    keypad.set_ring(1, (led for led in [1, 2]))  # any iterable of ints
    keypad.set_ring_blink({3})
    keypad.set_top(1, 5)
    rig.settle()
    assert keypad.ring(1) == [1, 2]
    assert int(twin.objects["led_on_rings"]) & 0xFFFF == 0b11
    assert twin.objects["led_blink_rings"] == 0b100
    with pytest.raises(ValueError, match=r"ring 1 has LEDs 1..16, not \[17\]"):
        keypad.set_ring(1, [17])
