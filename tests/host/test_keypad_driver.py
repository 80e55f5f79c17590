"""The Keypad driver against the keypad twin, in both quirk profiles and generations: in
simulated time, and the tests that use threads on a virtual bus in real time."""

from __future__ import annotations

import threading
from collections.abc import Iterator

import pytest

from blinkcan.host import HealthEvent, KeyEvent, Keypad, SdoAbortError
from tests.host.conftest import FLAVOUR_IDS, FLAVOURS, Rig, simulated_rig, threaded_rig


@pytest.fixture(params=FLAVOURS, ids=FLAVOUR_IDS)
def rig(request: pytest.FixtureRequest) -> Iterator[Rig]:
    yield from simulated_rig(request)


@pytest.fixture(params=FLAVOURS, ids=FLAVOUR_IDS)
def real_rig(request: pytest.FixtureRequest) -> Iterator[Rig]:
    yield from threaded_rig(request)


def keys(rig: Rig) -> list[dict[str, object]]:
    return rig.emulator.snapshot(rig.keypad)["keys"]  # type: ignore[no-any-return]


def test_identity_reads_versions_the_right_way_round(rig: Rig) -> None:
    identity = Keypad(rig.host).identity()
    assert (identity.hardware_version, identity.software_version) == ("V_01", rig.firmware)
    assert (identity.vendor_id, identity.model_id, identity.device_type,
            identity.serial_number) == (0x3E2, "PKP2600SI", 0x000B0191, "FFFFFFFF")


def test_key_events_by_callback_and_iterator(real_rig: Rig) -> None:
    keypad = Keypad(real_rig.host, long_press=0.1)
    real_rig.wait_until(
        lambda: real_rig.emulator.snapshot(real_rig.keypad)["nmt_state"] == "operational")
    seen: list[KeyEvent] = []
    keypad.on_key(seen.append)
    received: list[tuple[int, str]] = []
    reader = threading.Thread(target=lambda: received.extend(
        (e.key, e.action) for e in keypad.events(timeout=0.5)))
    reader.start()
    real_rig.sleep(0.02)
    real_rig.emulator.press(real_rig.keypad, 5)
    real_rig.sleep(0.2)
    real_rig.emulator.release(real_rig.keypad, 5)
    real_rig.emulator.press(real_rig.keypad, 12)
    real_rig.emulator.release(real_rig.keypad, 12)
    reader.join()
    expected = [(5, "press"), (5, "long press"), (5, "release"), (12, "press"), (12, "release")]
    assert [(e.key, e.action) for e in seen] == expected
    assert received == expected


def test_leds_steady_blinking_and_alternating(rig: Rig) -> None:
    keypad = Keypad(rig.host)
    keypad.set_leds({1: "red", 2: "amber", 3: "white"}, blink={4: "blue"})
    keypad.set_led(5, "red", blink="green")
    rig.wait_until(lambda: keys(rig)[4]["alternate"])
    shown = keys(rig)
    assert [k["phases"] for k in shown[:5]] == [
        ["red", "red"], ["yellow", "yellow"], ["white", "white"], ["off", "blue"],
        ["red", "green"]]
    assert shown[5]["phases"] == ["off", "off"]


def test_led_changes_are_batched_into_the_fewest_pdos(rig: Rig) -> None:
    keypad = Keypad(rig.host)
    rig.sniffed()  # the NMT start
    keypad.clear_leds()  # the first picture goes out whole: the keypad's state is unknown
    assert [f.can_id for f in rig.sniffed()] == [0x215, 0x315]
    with keypad.batch():
        for key in range(1, 13):
            keypad.set_led(key, "green")
    assert [f.can_id for f in rig.sniffed()] == [0x215]  # one PDO, blink unchanged
    keypad.set_led(1, "green")
    assert rig.sniffed() == []  # nothing changed, nothing sent


def test_brightness_and_backlight(rig: Rig) -> None:
    keypad = Keypad(rig.host)
    keypad.set_brightness(20)
    keypad.set_backlight("cyan", 40)
    rig.wait_until(lambda: rig.emulator.snapshot(rig.keypad)["backlight"] == {"colour": "cyan",
                                                                         "level": 40})
    assert rig.emulator.snapshot(rig.keypad)["indicator_brightness"] == 20


def test_leds_come_back_after_a_power_cycle(rig: Rig) -> None:
    keypad = Keypad(rig.host)
    keypad.set_led(7, "magenta")
    keypad.set_backlight(level=30)
    rig.wait_until(lambda: keys(rig)[6]["colour"] == "magenta")
    rig.emulator.power_cycle(rig.keypad)
    rig.wait_until(lambda: keys(rig)[6]["colour"] == "magenta"
                   and rig.emulator.snapshot(rig.keypad)["backlight"]["level"] == 30)
    snapshot = rig.emulator.snapshot(rig.keypad)
    assert snapshot["nmt_state"] == "operational"
    assert snapshot["backlight"]["level"] == 30


def test_heartbeat_lost_and_back(rig: Rig) -> None:
    keypad = Keypad(rig.host)
    keypad.monitor_heartbeat(0.1)
    rig.sleep(0.3)
    events = keypad.health_events(timeout=2.0)
    rig.emulator.power_off(rig.keypad)
    assert "lost" in [e.kind for e in _until(events, "lost")]
    rig.emulator.power_on(rig.keypad)
    kinds = [e.kind for e in _until(events, "boot-up")]
    assert kinds[-2:] == ["back", "boot-up"]  # a late heartbeat may add a lost/back before


def _until(events: Iterator[HealthEvent], kind: str) -> list[HealthEvent]:
    """Events up to and including the first of ``kind``."""
    seen = []
    for event in events:
        seen.append(event)
        if event.kind == kind:
            return seen
    raise AssertionError(f"no {kind!r} event; saw {[e.kind for e in seen]}")


def test_settings_through_the_keypads_own_objects(rig: Rig) -> None:
    keypad = Keypad(rig.host)
    keypad.set_startup_show("fast flash")
    keypad.set_periodic_key_state(0.5)
    keypad.set_default_backlight_colour("violet")  # errata P22: violet is magenta
    keypad.set_bitrate(250_000, confirm=True)  # errata B1: keypad code 03h
    settings = rig.emulator.snapshot(rig.keypad)["settings"]
    assert (settings["startup_led_show"], settings["tpdo1_event_timer"],
            settings["default_backlight_colour"], settings["baud_rate"]) == (2, 500, 6, 3)


@pytest.mark.parametrize(("call", "message"), [
    (lambda k: k.set_led(13, "red"), r"key 13 outside 1..12"),
    (lambda k: k.set_led(1, "purple"), r"unknown LED colour 'purple'"),
    (lambda k: k.set_brightness(64), r"brightness 64 outside 0..63"),
    (lambda k: k.set_backlight("pink"), r"unknown backlight colour 'pink'"),
    (lambda k: k.set_node_id(0x80, confirm=True), r"node id 0x80 outside"),
    (lambda k: k.set_node_id(0x20), r"confirm=True"),
    (lambda k: k.set_bitrate(800_000, confirm=True), r"does not run at 800000"),
    (lambda k: k.write("producer_heartbeat_time", 5), r"takes 0x0, 0xa..0xfeff"),
    (lambda k: k.set_startup_show("disco"), r"startup show must be one of"),
    (lambda k: k.switch_to_j1939(), r"confirm=True"),
])
def test_misuse_raises_and_sends_nothing(rig: Rig, call: object, message: str) -> None:
    keypad = Keypad(rig.host, start=False)
    rig.sniffed()
    with pytest.raises(ValueError, match=message):
        call(keypad)  # type: ignore[operator]
    assert rig.sniffed() == []


def test_an_abort_names_node_object_and_meaning(rig: Rig) -> None:
    keypad = Keypad(rig.host)
    with pytest.raises(SdoAbortError, match=r"node 15h 1001h/00: aborted 06020000h"):
        keypad.sdo.upload(0x1001, 0)


def test_overlapping_requests_never_lose_an_answer(real_rig: Rig) -> None:
    real_rig.emulator.response_delay = 0.01  # the keypad now drops overlapping requests
    keypad = Keypad(real_rig.host)
    results: list[object] = []

    def reader(name: str) -> None:
        results.extend(keypad.read(name) for _ in range(5))

    threads = [threading.Thread(target=reader, args=(name,))
               for name in ("device_type", "vendor_id", "node_id")]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert sorted(map(str, results)) == sorted(
        ["721297"] * 5 + ["994"] * 5 + ["21"] * 5)


def test_the_driver_finds_the_generation(rig: Rig) -> None:
    assert Keypad(rig.host).generation == rig.generation


def test_a_backlight_level_keeps_the_colour_on_both_generations(rig: Rig) -> None:
    keypad = Keypad(rig.host)
    keypad.set_backlight("blue", 10)
    keypad.set_backlight(level=40)  # generation 2 would fall back to the default colour
    rig.wait_until(lambda: rig.emulator.snapshot(rig.keypad)["backlight"] == {"colour": "blue",
                                                                         "level": 40})


def test_setting_red_leds_never_clears_green_1_to_4(rig: Rig) -> None:
    keypad = Keypad(rig.host)
    keypad.set_leds({1: "green", 2: "green"})
    keypad.set_led(3, "red")
    rig.wait_until(lambda: keys(rig)[2]["colour"] == "red")
    assert [k["colour"] for k in keys(rig)[:3]] == ["green", "green", "red"]


def test_generation_2_watchdog_and_sync(rig: Rig) -> None:
    keypad = Keypad(rig.host, restore=False)
    if rig.generation == "1.1":
        with pytest.raises(ValueError, match="no consumer heartbeat"):
            keypad.watch_host(0.05)
        with pytest.raises(ValueError, match="no synchronous PDOs"):
            keypad.set_synchronous()
        return
    keypad.set_synchronous(leds=True, key_state_every=1)
    keypad.set_led(6, "cyan")
    rig.sleep(0.05)
    assert keys(rig)[5]["colour"] == "off"  # held until a SYNC
    sync = rig.host.produce_sync(0.02)
    rig.wait_until(lambda: keys(rig)[5]["colour"] == "cyan")
    sync.cancel()
    keypad.set_synchronous(leds=False, key_state_every=None)
    keypad.watch_host(0.15)  # margin: a busy machine delays heartbeats
    keypad.set_led(7, "red")
    rig.wait_until(lambda: keys(rig)[6]["colour"] == "red")
    events = keypad.health_events(timeout=3.0)
    keypad.stop_host_heartbeat()
    assert any(e.kind == "watchdog" for e in events)  # the driver saw the trip
    assert keys(rig)[6]["colour"] == "off"  # restore=False: the LEDs stay dark


def test_j1939_and_back(rig: Rig) -> None:
    keypad = Keypad(rig.host)
    keypad.switch_to_j1939(confirm=True)
    rig.wait_until(lambda: rig.emulator.snapshot(rig.keypad)["protocol"] == "j1939")
    events = keypad.health_events(timeout=1.0)
    keypad.switch_to_canopen()
    assert next(events).kind == "boot-up"
    rig.wait_until(lambda: rig.emulator.snapshot(rig.keypad)["nmt_state"] == "operational")


def test_an_event_iterator_sees_events_from_its_creation_on(rig: Rig) -> None:
    keypad = Keypad(rig.host)
    rig.wait_until(lambda: rig.emulator.snapshot(rig.keypad)["nmt_state"] == "operational")
    events = keypad.events(timeout=1.0)  # not iterated yet
    rig.emulator.press(rig.keypad, 2)
    rig.sleep(0.05)
    assert next(events).key == 2
