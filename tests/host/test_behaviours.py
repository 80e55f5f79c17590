"""Momentary, Toggle and Cycle: the LED follows the state; on_change reports it (in simulated
time)."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from blinkcan.host import Cycle, Keybox, Keypad, Momentary, Toggle
from tests.host.conftest import FLAVOUR_IDS, FLAVOURS, Rig, simulated_rig


@pytest.fixture(params=FLAVOURS, ids=FLAVOUR_IDS)
def rig(request: pytest.FixtureRequest) -> Iterator[Rig]:
    yield from simulated_rig(request)


def colour(rig: Rig, key: int) -> str:
    return str(rig.emulator.snapshot(rig.keypad)["keys"][key - 1]["colour"])


def press(rig: Rig, key: int) -> None:
    rig.emulator.press(rig.keypad, key)
    rig.emulator.release(rig.keypad, key)


def test_toggle_momentary_and_cycle(rig: Rig) -> None:
    keypad = Keypad(rig.host)
    rig.wait_until(lambda: rig.emulator.snapshot(rig.keypad)["nmt_state"] == "operational")
    changes: list[tuple[str, int]] = []
    Toggle(keypad, 1, on_change=lambda s: changes.append(("toggle", s)))
    Momentary(keypad, 2, on="amber", on_change=lambda s: changes.append(("momentary", s)))
    Cycle(keypad, 3, ["off", "green", "amber", "red"],
          on_change=lambda s: changes.append(("cycle", s)))
    press(rig, 1)
    rig.wait_until(lambda: colour(rig, 1) == "green")
    rig.emulator.press(rig.keypad, 2)
    rig.wait_until(lambda: colour(rig, 2) == "yellow")
    rig.emulator.release(rig.keypad, 2)
    rig.wait_until(lambda: colour(rig, 2) == "off")
    for _ in range(5):
        press(rig, 3)
    rig.wait_until(lambda: colour(rig, 3) == "green")  # off, green, yellow, red, off, green
    press(rig, 1)
    rig.wait_until(lambda: colour(rig, 1) == "off")
    assert changes == [("toggle", 1), ("momentary", 1), ("momentary", 0), ("cycle", 1),
                       ("cycle", 2), ("cycle", 3), ("cycle", 0), ("cycle", 1), ("toggle", 0)]


def test_behaviour_arguments_are_checked(rig: Rig) -> None:
    keypad = Keypad(rig.host, start=False)
    with pytest.raises(ValueError, match="key 0 outside"):
        Toggle(keypad, 0)
    with pytest.raises(ValueError, match="unknown LED colour 'pink'"):
        Cycle(keypad, 1, ["off", "pink"])
    with pytest.raises(ValueError, match="at least 2 colours"):
        Cycle(keypad, 1, ["red"])


def test_keybox_restores_outputs_after_a_reboot_only_when_asked(rig: Rig) -> None:
    asked = Keybox(rig.host, restore_outputs=True)
    asked.set_outputs(high=[3, 5])
    rig.emulator.power_cycle(rig.keybox)
    rig.wait_until(lambda: asked.states()[5] == "high")
    assert {p for p, s in asked.states().items() if s == "high"} == {3, 5}
    asked.close()
    plain = Keybox(rig.host)
    plain.on(8)
    rig.emulator.power_cycle(rig.keybox)
    rig.wait_until(lambda: rig.emulator.snapshot(rig.keybox)["nmt_state"] == "operational")
    assert plain.state(8) == "off"


def test_behaviours_take_every_key_with_an_led_of_the_model() -> None:
    # issue 19: Toggle(pkp3500_keypad, 14) raised "key 14 outside 1..12"
    from blinkcan.testing import Rig
    from blinkcan.twin import KeypadTwin

    with Rig() as bench:
        twin = bench.add(KeypadTwin(node_id=0x15, model="pkp-3500-mt"))
        keypad = Keypad(bench.bus, 0x15, model="pkp-3500-mt")
        bench.advance(10)  # past the start-up LED show
        toggle = Toggle(keypad, 14)
        bench.act(lambda now: twin.press(14, now))
        bench.act(lambda now: twin.release(14, now))
        bench.settle()
        assert toggle.state == 1
        assert twin.snapshot()["keys"][13]["colour"] == "green"
        with pytest.raises(ValueError, match="key 11 has no LED"):
            Toggle(keypad, 11)  # the encoder's push key (its LED bit is a hole)
        with pytest.raises(ValueError, match=r"1\.\.15"):
            Toggle(keypad, 16)
        keypad.close()
