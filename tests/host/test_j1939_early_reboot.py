"""A J1939 keypad that powers on before the driver heard its first heartbeat (hatk10).

§18: the heartbeat counter goes +1 per message and starts at 00h, both when the heartbeat is
turned on and when a keypad with it stored on powers on: the first heartbeat heard cannot say
whether the keypad rebooted before it. The driver treats it as "state unknown" and sends what
it commanded again (idempotent on the keypad), with no "boot-up" event (it may not be one).
"""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from blinkcan import Keypad
from blinkcan.devices.registry import models
from blinkcan.testing import Rig, frames_of
from blinkcan.twin import KeypadTwin

J1939_MODELS = [pytest.param(m.name, g, id=f"{m.name}@{g}") for m in models()
                for g in m.generations if "j1939" in m.description(g).features]
PERIOD = 0.1  # s: the heartbeat the driver monitors (§18, 75h 0Ah)
#: when the keypad reboots, seconds after monitor_heartbeat(): None = before it is called
MOMENTS = {
    "before monitoring": None,
    "before the first heartbeat": 0.05,
    "just after the first heartbeat": PERIOD + 0.005,
    "between the second and third": 2 * PERIOD + 0.05,
}


@pytest.fixture
def rig() -> Iterator[Rig]:
    with Rig() as rig:
        yield rig


def driven(rig: Rig, model: str, generation: str) -> tuple[KeypadTwin, Keypad, list[str]]:
    """A J1939 keypad twin (heartbeat off, its default) and a driver that lit key 5 green,
    key 11 red blinking and set the brightness; the health events go into the list."""
    twin = rig.add(KeypadTwin(model=model, manual=generation, protocol="j1939"))
    rig.settle()
    keypad = Keypad(rig.bus, model=model, generation=generation, protocol="j1939")
    events: list[str] = []
    keypad.on_health(lambda event: events.append(event.kind))
    keypad.set_led(5, "green")
    keypad.set_led(11, "red", blink="red")
    keypad.set_brightness(20)
    rig.advance(2.0)  # the startup show is over
    return twin, keypad, events


def shown(twin: KeypadTwin) -> tuple[list[str], int]:
    snapshot = twin.snapshot()
    return [key["colour"] for key in snapshot["commanded"]], snapshot["indicator_brightness"]


@pytest.mark.parametrize(("model", "generation"), J1939_MODELS)
@pytest.mark.parametrize("moment", list(MOMENTS), ids=list(MOMENTS))
def test_leds_come_back_whenever_the_keypad_reboots(rig: Rig, model: str, generation: str,
                                                    moment: str) -> None:
    twin, keypad, events = driven(rig, model, generation)
    before = shown(twin)
    assert (before[0][4], before[0][10], before[1]) == ("green", "red", 20)
    after = MOMENTS[moment]
    if after is None:
        rig.power_cycle(twin, off_time=0.01)
    keypad.monitor_heartbeat(PERIOD)
    if after is not None:
        rig.advance(after)
        rig.power_cycle(twin, off_time=0.01)
    rig.advance(2.0)  # the startup show is over, heartbeats heard
    assert shown(twin) == before
    if after is not None and after > PERIOD:  # a heartbeat before the reboot: counter back
        assert "boot-up" in events
    keypad.close()


@pytest.mark.parametrize(("model", "generation"), J1939_MODELS)
def test_no_boot_up_for_a_keypad_that_did_not_reboot(rig: Rig, model: str,
                                                     generation: str) -> None:
    """The first heartbeat re-sends what the driver commanded once, and says nothing."""
    twin, keypad, events = driven(rig, model, generation)
    before = shown(twin)
    start = len(rig.frames)
    keypad.monitor_heartbeat(PERIOD)
    rig.advance(3.0)  # 256 heartbeats would wrap the counter (J-6): fewer here
    assert "boot-up" not in events
    assert shown(twin) == before
    single_led = [f for f in frames_of(rig.frames[start:])
                  if f.extended and f.can_id & 0xFFFF00 == 0xEF2100 << 8 and f.data[2] == 0x01]
    assert len(single_led) <= 2  # keys 5 and 11 at most once again, not at every heartbeat
    keypad.close()
