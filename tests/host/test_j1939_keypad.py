"""The Keypad driver over J1939 (spec/pkp-2600-si-j1939.md), in simulated time (Rig)."""

from __future__ import annotations

import time
import uuid
from collections.abc import Callable, Iterator

import can
import pytest

from blinkcan import Keypad
from blinkcan.cli.render import key_cell
from blinkcan.decode import Decoder
from blinkcan.decode.view import BusView
from blinkcan.devices.registry import models
from blinkcan.host import KeyEvent, NoDeviceError
from blinkcan.host.j1939_keypad import KeypadGoneError, look_of, scan_j1939
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
    rig.settle()
    before = len(rig.frames)
    keypad.set_led(3, "red")
    rig.settle()  # the key named, nothing else (§7a): the other keys keep what they show
    assert frames_of(rig.frames[before:]) == [
        Frame(0x18EF2100, bytes.fromhex("041B0103010100FF"), extended=True)]
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
        keypad.write("node_id", 0x16)
    keypad.write("producer_heartbeat_time", 100)  # §18: the J1939 heartbeat, x 10 ms
    rig.settle()
    assert twin.snapshot()["j1939"]["heartbeat_ms"] == 100
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


# -- issue 20: every model whose description declares "j1939", from the registry -------------

J1939_MODELS = [pytest.param(m.name, g, id=f"{m.name}@{g}") for m in models()
                for g in m.generations if "j1939" in m.description(g).features]
CLAIM_ON = "041B7401FFFFFFFF"  # §20 address claim at boot
HEARTBEAT_100_MS = "041B75010AFFFFFF"  # §18


def configured(rig: Rig, twin: KeypadTwin, *commands: str) -> KeypadTwin:
    """``twin`` with the J1939 ``commands`` (hex) stored, then powered on again."""
    for data in commands:
        rig.act(lambda now, data=data: twin.receive(  # type: ignore[misc]
            Frame(0x18EF2100, bytes.fromhex(data), extended=True), now))
    rig.power_cycle(twin)
    rig.advance(2.0)  # the startup show and the claim are over
    return twin


def j1939_pair(rig: Rig, model: str, generation: str, claim: bool = False
               ) -> tuple[KeypadTwin, Keypad]:
    """A keypad twin of ``model`` in J1939 mode (with address claim and a 100 ms heartbeat
    when ``claim``) and a driver of it."""
    twin = rig.add(KeypadTwin(model=model, manual=generation, protocol="j1939"))
    rig.settle()
    if claim:
        configured(rig, twin, CLAIM_ON, HEARTBEAT_100_MS)
    keypad = Keypad(rig.bus, model=model, generation=generation, protocol="j1939")
    rig.settle()
    return twin, keypad


def commands_to(rig: Rig, start: int, address: int) -> list[Frame]:
    return [f for f in frames_of(rig.frames[start:])
            if f.extended and f.can_id & 0xFFFF00 == (0xEF00 | address) << 8]


@pytest.mark.parametrize(("model", "generation"), J1939_MODELS)
def test_set_led_changes_the_key_it_names_and_nothing_else(rig: Rig, model: str,
                                                            generation: str) -> None:
    """Issue 20 item 1: §7a single-LED commands for single LEDs; no picture of all keys."""
    twin, first = j1939_pair(rig, model, generation)
    first.set_led(5, "green")
    first.close()
    second = Keypad(rig.bus, model=model, generation=generation, protocol="j1939")
    before = len(rig.frames)
    second.set_led(3, "red")
    rig.settle()
    assert commands_to(rig, before, 0x21) == [
        Frame(0x18EF2100, bytes.fromhex("041B0103010100FF"), extended=True)]
    assert [k["colour"] for k in twin.snapshot()["commanded"]][2:5] == ["red", "off", "green"]
    before = len(rig.frames)
    second.clear_leds()  # a full picture when the caller asks for one
    rig.settle()
    assert len(commands_to(rig, before, 0x21)) == len(second.description.face.led_keys)
    second.close()


@pytest.mark.parametrize(("model", "generation"), J1939_MODELS)
def test_no_keypad_at_the_address_is_no_device(rig: Rig, model: str, generation: str) -> None:
    """Issue 20 item 3: J1939 commands are unacknowledged, so the driver hears the keypad
    first (§11 revision, §20 claim) and sends no command to an empty address."""
    rig.add(KeypadTwin(model=model, manual=generation, protocol="j1939"))
    rig.settle()
    before = len(rig.frames)
    with pytest.raises(NoDeviceError, match="no keypad heard at 30h"):
        Keypad(rig.bus, model=model, generation=generation, protocol="j1939", address=0x30)
    rig.settle()
    assert not [f for f in commands_to(rig, before, 0x30) if f.data[2] != 0x2A]


@pytest.mark.parametrize(("model", "generation"), J1939_MODELS)
def test_identity_over_j1939(rig: Rig, model: str, generation: str) -> None:
    """Issue 20 item 2: revision (§11), NAME, address, claim (§20), heartbeat (§18); no SDO."""
    twin, keypad = j1939_pair(rig, model, generation, claim=True)
    rig.advance(0.3)
    before = len(rig.frames)
    identity = keypad.identity()
    assert (identity.address, identity.software_version, identity.claim) == (0x21, "V2.6",
                                                                           "claimed")
    assert identity.name == twin.snapshot()["j1939"]["name"]
    assert identity.heartbeat is not None
    assert "keys held: none" in identity.heartbeat
    assert not [f for f in frames_of(rig.frames[before:]) if not f.extended]  # no SDO
    keypad.close()


@pytest.mark.parametrize(("model", "generation"), J1939_MODELS)
def test_the_driver_follows_its_keypad_by_name_after_a_claim(rig: Rig, model: str,
                                                             generation: str) -> None:
    """Issue 20 items 5 and 6 (J-5): a lower NAME claims 21h, the keypad claims 22h; the
    driver says so, sends its commands to 22h and never to the other node."""
    twin, keypad = j1939_pair(rig, model, generation, claim=True)
    events: list[tuple[str, int]] = []
    keypad.on_health(lambda e: events.append((e.kind, e.node_id)))
    keys: list[KeyEvent] = []
    keypad.on_key(keys.append)
    lower = bytes(8)  # the lowest NAME there is: it wins 21h
    rig.act(lambda now: [Frame(0x18EEFF21, lower, extended=True)])
    rig.settle()
    assert twin.snapshot()["j1939"]["source_address"] == 0x22
    assert events[:2] == [("address lost", 0x21), ("moved", 0x22)]
    before = len(rig.frames)
    keypad.set_led(4, "blue")
    rig.settle()
    assert commands_to(rig, before, 0x21) == []
    assert [f.can_id for f in commands_to(rig, before, 0x22)] == [0x18EF2200]
    assert twin.snapshot()["commanded"][3]["colour"] == "blue"
    rig.tap(twin, 2)
    assert [(e.key, e.action) for e in keys] == [(2, "press"), (2, "release")]
    keypad.close()


@pytest.mark.parametrize(("model", "generation"), J1939_MODELS)
def test_a_keypad_that_cannot_claim_is_gone(rig: Rig, model: str, generation: str) -> None:
    """Issue 20 item 6: the address went to another node and the keypad has none (J-5
    "cannot claim"): the driver raises instead of commanding the other node."""
    twin, keypad = j1939_pair(rig, model, generation, claim=True)
    rig.act(lambda now: [Frame(0x18EEFF21, bytes(8), extended=True)])
    rig.act(lambda now: [Frame(0x18EEFF22, bytes(8), extended=True)])
    rig.settle()
    # the keypad moved to 22h, then lost that too; the driver never sends to a taken address
    name = twin.snapshot()["j1939"]["name"].replace(" ", "")
    rig.act(lambda now: [Frame(0x18EEFFFE, bytes.fromhex(name), extended=True)])
    rig.settle()
    before = len(rig.frames)
    with pytest.raises(KeypadGoneError, match="lost its address"):
        keypad.set_led(4, "blue")
    rig.settle()
    assert commands_to(rig, before, 0x21) == commands_to(rig, before, 0x22) == []
    keypad.close()


@pytest.mark.parametrize(("model", "generation"), J1939_MODELS)
@pytest.mark.parametrize("told_by", ["claim", "heartbeat"])
def test_leds_are_restored_after_a_power_cycle(rig: Rig, model: str, generation: str,
                                               told_by: str) -> None:
    """Issue 20 items 5 and 7: the keypad's claim (§20) or heartbeat counter from 00h (§18)
    says it powered on: "boot-up", and the LEDs the driver commanded come back."""
    twin = rig.add(KeypadTwin(model=model, manual=generation, protocol="j1939"))
    rig.settle()
    configured(rig, twin, CLAIM_ON if told_by == "claim" else HEARTBEAT_100_MS)
    keypad = Keypad(rig.bus, model=model, generation=generation, protocol="j1939")
    keypad.monitor_heartbeat(0.1) if told_by == "heartbeat" else None
    events: list[str] = []
    keypad.on_health(lambda e: events.append(e.kind))
    keypad.set_led(5, "green")
    rig.advance(0.5)
    rig.power_cycle(twin, off_time=0.5)
    rig.advance(2.0)  # the startup show is over
    commanded = [k["colour"] for k in twin.snapshot()["commanded"]]
    assert commanded[4] == "green"
    assert commanded.count("off") == len(commanded) - 1
    assert "boot-up" in events
    if told_by == "heartbeat":
        assert events.index("lost") < events.index("back")
    keypad.close()


def test_a_claim_answering_a_request_is_no_power_on(rig: Rig) -> None:
    """J1939-81: claims that answer a Request for Address Claimed (a scan) are not a boot."""
    twin = configured(rig, rig.add(KeypadTwin(protocol="j1939")), CLAIM_ON)
    keypad = Keypad(rig.bus, protocol="j1939")
    events: list[str] = []
    keypad.on_health(lambda e: events.append(e.kind))
    scan_j1939(keypad.host, listen=0.1)
    rig.settle()
    assert events == []
    assert twin.snapshot()["j1939"]["address_claim"] == "claimed"
    keypad.close()


@pytest.mark.parametrize(("model", "generation"), J1939_MODELS)
def test_amber_and_yellow_green_are_kept_as_commanded(rig: Rig, model: str,
                                                      generation: str) -> None:
    """Issue 20 item 4: 04h yellow, 08h amber/orange and 09h yellow/green are three colours
    (§7a): the driver sends each code, and the twin, the decoder, the monitor's view and its
    key cells name each as commanded (the RGB mixture stays the twin's "rgb" view)."""
    twin, keypad = j1939_pair(rig, model, generation)
    before = len(rig.frames)
    keypad.set_led(4, "yellow")
    keypad.set_led(5, "amber")
    keypad.set_led(6, "yellow/green", blink="orange")
    rig.settle()
    sent = commands_to(rig, before, 0x21)
    assert [f.data.hex() for f in sent] == ["041b0104040100ff", "041b0105080100ff",
                                           "041b0106090308ff"]
    snapshot = twin.snapshot()
    assert [(k["colour"], k["phases"]) for k in snapshot["commanded"][3:6]] == [
        ("yellow", ["yellow", "yellow"]), ("amber", ["amber", "amber"]),
        ("yellow/green", ["yellow/green", "amber"])]
    assert snapshot["commanded"][4]["rgb"]["colour"] == "yellow"  # red + green, J-4
    rig.advance(6.0)  # after the startup show the keys show what was commanded
    assert [k["phases"][0] for k in rig.snapshot(twin)["keys"][3:6]] == [
        "yellow", "amber", "yellow/green"]
    decoder = Decoder()
    view = BusView(decoder)
    texts = []
    for frame in sent:
        event = decoder.decode(frame)
        view.update(event)
        texts.append(event.text)
    assert any("LED 5 amber" in text for text in texts)
    assert any("LED 6 alternates yellow/green/amber" in text for text in texts)
    phases = {key: (a, b) for key, a, b in view.nodes[0x21].key_phases()}
    assert [phases[4], phases[5], phases[6]] == [
        ("yellow", "yellow"), ("amber", "amber"), ("yellow/green", "amber")]
    assert "yel/grn" in key_cell(6, "yellow/green", "yellow/green").plain
    with pytest.raises(ValueError, match="yellow/green"):
        keypad.set_led(1, "purple")
    keypad.close()
