"""The Keypad driver over J1939 (spec/pkp-2600-si-j1939.md), in simulated time (Rig)."""

from __future__ import annotations

import time
import uuid
from collections.abc import Callable, Iterator

import can
import pytest

from blinkcan import Keypad
from blinkcan.host import KeyEvent
from blinkcan.host.j1939_keypad import look_of, scan_j1939
from blinkcan.protocol import Frame
from blinkcan.runtime import Emulator
from blinkcan.testing import Rig, frames_of
from blinkcan.twin import KeypadTwin


@pytest.fixture
def rig() -> Iterator[Rig]:
    with Rig() as rig:
        yield rig


def colours(twin: KeypadTwin) -> list[tuple[str, list[str]]]:
    return [(k["colour"], k["phases"]) for k in twin.snapshot()["commanded"]]


def test_leds_brightness_and_backlight_over_j1939(rig: Rig) -> None:
    twin = rig.add(KeypadTwin(protocol="j1939"))
    keypad = Keypad(rig.bus, protocol="j1939", address=0x21)
    keypad.set_led(3, "red")
    rig.settle()
    sent = frames_of(rig.frames)  # the first time, the whole picture (§7a)
    assert len(sent) == 12
    assert sent[2] == Frame(0x18EF2100, bytes.fromhex("041B0103010100FF"), extended=True)
    assert sent[0] == Frame(0x18EF2100, bytes.fromhex("041B0101000000FF"), extended=True)
    before = len(rig.frames)
    keypad.set_led(11, "red", blink="green")
    keypad.set_led(2, "off", blink="blue")
    keypad.set_led(3, "red")  # unchanged: nothing sent
    rig.settle()
    assert frames_of(rig.frames[before:]) == [
        Frame(0x18EF2100, bytes.fromhex("041B010B010302FF"), extended=True),
        Frame(0x18EF2100, bytes.fromhex("041B0102030200FF"),
              extended=True)]
    assert colours(twin)[10] == ("red", ["red", "green"])
    assert colours(twin)[1][1] == ["blue", "off"]  # blinks blue (§7a starts lit)
    assert colours(twin)[2][0] == "red"
    keypad.set_brightness(32)
    keypad.set_backlight("green", 16)
    rig.settle()
    snapshot = twin.snapshot()
    assert (snapshot["indicator_brightness"], snapshot["backlight"]) == (
        32, {"colour": "green", "level": 16})
    with pytest.raises(ValueError, match=r"key 13 outside 1\.\.12"):
        keypad.set_led(13, "red")
    keypad.close()


def test_key_events_and_long_press_over_j1939(rig: Rig) -> None:
    twin = rig.add(KeypadTwin(protocol="j1939"))
    keypad = Keypad(rig.bus, protocol="j1939", long_press=0.5)
    events: list[KeyEvent] = []
    keypad.on_key(events.append)
    rig.settle()
    start = rig.now
    rig.long_press(twin, 5, hold=0.7)
    assert [(e.key, e.action, round(e.time - start, 6)) for e in events] == [
        (5, "press", 0.0), (5, "long press", 0.5), (5, "release", 0.7)]
    keypad.close()


def test_settings_go_as_j1939_commands(rig: Rig) -> None:
    twin = rig.add(KeypadTwin(protocol="j1939"))
    keypad = Keypad(rig.bus, protocol="j1939")
    keypad.set_startup_show("off")
    keypad.set_demo_mode(False)
    keypad.set_default_backlight_colour("blue")
    keypad.set_startup_levels(brightness=10, backlight=20)
    keypad.set_periodic_key_state(0.2)
    rig.settle()
    settings = twin.j1939.settings
    assert (settings["startup_led_show"], settings["backlight_colour"],
            settings["startup_led_brightness"], settings["startup_backlight_level"],
            settings["periodic_key_state"], settings["key_message_period"]) == (
        0, 3, 10, 20, 1, 20)
    assert keypad.j1939 is not None
    assert keypad.j1939.software_revision() == "V2.6"  # §11
    with pytest.raises(ValueError, match="CANopen setting"):
        keypad.write("producer_heartbeat_time", 100)
    keypad.close()


@pytest.mark.parametrize("manual", ["1.1", "1.5"])
def test_switched_power_cycled_driven_over_j1939_and_switched_back(rig: Rig, manual: str
                                                                   ) -> None:
    """Issue 13 "done when": the whole round trip on the twin, one driver throughout."""
    twin = rig.add(KeypadTwin(manual=manual))
    keypad = Keypad(rig.bus, 0x15, generation=manual)
    events: list[KeyEvent] = []
    keypad.on_key(events.append)
    rig.settle()
    keypad.set_led(1, "green")
    keypad.switch_to_j1939(confirm=True)
    rig.settle()
    assert (twin.snapshot()["protocol"], keypad.protocol) == ("j1939", "j1939")
    assert colours(twin)[0][0] == "green"  # the driver sent its picture again
    rig.power_cycle(twin)
    assert twin.snapshot()["protocol"] == "j1939"  # stored
    keypad.set_led(4, "blue", blink="red")
    rig.tap(twin, 4)
    assert [(e.key, e.action) for e in events] == [(4, "press"), (4, "release")]
    assert colours(twin)[3] == ("blue", ["blue", "red"])
    keypad.switch_to_canopen()
    rig.until(lambda: twin.snapshot()["nmt_state"] == "operational")  # restarted by the driver
    assert (twin.snapshot()["protocol"], keypad.protocol) == ("canopen", "canopen")
    rig.settle()
    assert colours(twin)[3] == ("blue", ["blue", "red"])  # picture restored over CANopen
    keypad.set_led(6, "white")
    rig.tap(twin, 6)
    rig.settle()
    assert colours(twin)[5][0] == "white"
    assert [(e.key, e.action) for e in events][-2:] == [(6, "press"), (6, "release")]
    keypad.close()


def test_scan_finds_j1939_keypads(rig: Rig) -> None:
    rig.add(KeypadTwin(protocol="j1939"))
    moved = rig.add(KeypadTwin(protocol="j1939", node_id=0x16))
    rig.settle()
    rig.act(lambda now: moved.receive(
        Frame(0x18EF2100, bytes.fromhex("041B7030FFFFFFFF"), extended=True), now))
    found = scan_j1939(rig.bus, listen=0.2)
    assert [(f.address, f.software_revision) for f in found] == [(0x21, "V2.6"), (0x30, "V2.6")]


def test_look_of_follows_the_phase_model() -> None:
    assert look_of(0b001, 0) == look_of(0b001, 0)
    assert look_of(0, 0).state == 0
    assert (look_of(0b001, 0b011).state, look_of(0b001, 0b011).secondary) == (3, 0x02)
    assert (look_of(0b100, 0b100).state, look_of(0b100, 0b100).colour) == (2, 0x03)


def test_the_round_trip_on_a_virtual_bus_in_real_time() -> None:
    """The same round trip with the Emulator on python-can's ``virtual`` bus (threads, real
    time), as a controller application runs it."""
    channel = f"j1939-{uuid.uuid4()}"
    twin = KeypadTwin()
    device_bus = can.Bus(interface="virtual", channel=channel)
    host_bus = can.Bus(interface="virtual", channel=channel)
    events: list[KeyEvent] = []
    try:
        with Emulator(device_bus, [twin]) as emulator:
            keypad = Keypad(host_bus, 0x15)
            keypad.on_key(events.append)
            keypad.switch_to_j1939(confirm=True)
            emulator.power_cycle(twin)
            assert emulator.snapshot(twin)["protocol"] == "j1939"
            assert keypad.j1939 is not None
            assert keypad.j1939.software_revision() == "V2.6"
            keypad.set_led(9, "cyan")
            emulator.press(twin, 9)
            wait(lambda: [(e.key, e.action) for e in events] == [(9, "press")])
            # the LED command and the press travel on different threads (the emulator's reader,
            # the test's call): the command is applied, not necessarily before the press
            wait(lambda: emulator.snapshot(twin)["commanded"][8]["colour"] == "cyan")
            keypad.switch_to_canopen()
            wait(lambda: emulator.snapshot(twin)["nmt_state"] == "operational")
            wait(lambda: emulator.snapshot(twin)["commanded"][8]["colour"] == "cyan")
            assert keypad.identity().software_version == "V2.2"
            keypad.close()
    finally:
        device_bus.shutdown()
        host_bus.shutdown()


def wait(condition: Callable[[], object], timeout: float = 3.0) -> None:
    end = time.monotonic() + timeout
    while not condition():
        assert time.monotonic() < end, "condition not met in time"
        time.sleep(0.01)
