"""Issue 17 item 6: every public method of the drivers is thread-safe. Many threads drive one
driver at once on a virtual bus; no call raises, and what the device shows at the end is what
each thread commanded last."""

from __future__ import annotations

import threading
import uuid
from collections.abc import Callable, Iterable

import can
import pytest

from blinkcan.host import Keybox, Keypad
from blinkcan.host.pkp3500 import Pkp3500Keypad
from blinkcan.runtime import Emulator
from blinkcan.twin import KeyboxTwin, KeypadTwin
from blinkcan.twin.pkp3500 import Pkp3500Twin
from tests.host.conftest import quiet_keypad, wait_until

COLOURS = ("red", "green", "blue", "white", "magenta", "cyan", "yellow")


@pytest.fixture
def channel() -> str:
    return f"threads-{uuid.uuid4().hex}"


def _bench(channel: str, *twins: object) -> tuple[can.BusABC, can.BusABC, Emulator]:
    device_bus = can.Bus(interface="virtual", channel=channel)
    host_bus = can.Bus(interface="virtual", channel=channel)
    emulator = Emulator(device_bus, list(twins)).start()  # type: ignore[arg-type]
    return device_bus, host_bus, emulator


def _hammer(workers: list[Callable[[], None]]) -> list[BaseException]:
    """Run every worker in its own thread, all at once; the exceptions they raised."""
    errors: list[BaseException] = []
    start = threading.Barrier(len(workers))

    def run(work: Callable[[], None]) -> None:
        try:
            start.wait()
            work()
        except BaseException as error:  # collected and asserted
            errors.append(error)

    threads = [threading.Thread(target=run, args=(work,)) for work in workers]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(60)
    assert not [thread for thread in threads if thread.is_alive()]
    return errors


def _last_colour(key: int, calls: int) -> str:
    return COLOURS[(key + calls - 1) % len(COLOURS)]


def _repeat(action: Callable[[int], object], times: int) -> Callable[[], None]:
    def work() -> None:
        for n in range(times):
            action(n)
    return work


def _shown(emulator: Emulator, twin: KeypadTwin, keys: Iterable[int], field: str = "commanded"
           ) -> list[list[str]]:
    snapshot = emulator.snapshot(twin)[field]
    return [snapshot[key - 1]["phases"] for key in keys]


def _led_workers(keypad: Keypad, keys: Iterable[int], calls: int
                 ) -> list[Callable[[], None]]:
    def leds(key: int) -> Callable[[], None]:
        def work() -> None:
            for n in range(calls):
                if n % 50 == 0:
                    with keypad.batch():
                        keypad.set_led(key, COLOURS[(key + n) % len(COLOURS)])
                else:
                    keypad.set_led(key, COLOURS[(key + n) % len(COLOURS)])
        return work

    return [leds(key) for key in keys]


def test_many_threads_light_one_keypad(channel: str) -> None:
    twin = quiet_keypad()
    device_bus, host_bus, emulator = _bench(channel, twin)
    try:
        keypad = Keypad(host_bus, 0x15)
        calls = 400
        workers = _led_workers(keypad, range(1, 13), calls)
        workers += [_repeat(lambda n: keypad.set_brightness(n % 64), 200) for _ in range(2)]
        workers += [_repeat(lambda n: keypad.set_backlight(level=n % 64), 200)
                    for _ in range(2)]
        assert _hammer(workers) == []
        expected = [[_last_colour(key, calls)] * 2 for key in range(1, 13)]
        wait_until(lambda: _shown(emulator, twin, range(1, 13)) == expected)
        keypad.close()
    finally:
        emulator.stop()
        host_bus.shutdown()
        device_bus.shutdown()


def test_many_threads_drive_one_keybox_and_close_it_twice(channel: str) -> None:
    twin = KeyboxTwin(node_id=0x0C)
    device_bus, host_bus, emulator = _bench(channel, twin)
    try:
        other = Keybox(host_bus, 0x0C)  # another driver on the same bus, closed last
        box = Keybox(host_bus, 0x0C)
        calls = 12

        def pin_worker(pin: int) -> Callable[[], None]:
            def work() -> None:
                for n in range(calls):
                    if (n + pin) % 2:
                        box.on(pin)
                    else:
                        box.off(pin)
            return work

        workers = [pin_worker(pin) for pin in range(1, 14)]
        workers += [_repeat(lambda n: box.states(), 5),
                    _repeat(lambda n: (box.commanded, box.actual), 500),
                    _repeat(lambda n: box.watch_host(0.2), 5)]
        assert _hammer(workers) == []
        high = {pin for pin in range(1, 14) if (calls - 1 + pin) % 2}
        pins = emulator.snapshot(twin)["pins"]
        assert {p["pin"] for p in pins if p["state"] == "high"} == high
        assert box.commanded == high
        assert {pin for pin, state in box.actual.items() if state == "high"} == high
        assert _hammer([box.close, box.close]) == []
        other.on(1)  # the other driver's hold on the bus survived the double close
        assert emulator.snapshot(twin)["pins"][0]["state"] == "high"
        other.close()
        assert can.Notifier.find_instances(host_bus) == ()
    finally:
        emulator.stop()
        host_bus.shutdown()
        device_bus.shutdown()


def test_many_threads_drive_one_pkp3500(channel: str) -> None:
    twin = Pkp3500Twin(node_id=0x15, settings={"startup_led_show": 0})
    device_bus, host_bus, emulator = _bench(channel, twin)
    try:
        keypad = Pkp3500Keypad(host_bus, 0x15)
        face = keypad.description.face
        calls = 200

        def ring_worker(encoder: int) -> Callable[[], None]:
            leds = face.encoders[encoder - 1].ring_leds

            def work() -> None:
                for n in range(calls):
                    keypad.set_ring(encoder, leds[: n % len(leds) + 1])
            return work

        keys = face.led_keys
        workers = _led_workers(keypad, keys, calls)
        workers += [ring_worker(encoder) for encoder in range(1, len(face.encoders) + 1)]
        assert _hammer(workers) == []
        expected_rings = [list(face.encoders[e - 1].ring_leds)[: (calls - 1) % len(
            face.encoders[e - 1].ring_leds) + 1] for e in range(1, len(face.encoders) + 1)]
        assert [keypad.ring(e) for e in range(1, len(face.encoders) + 1)] == expected_rings
        word = sum(1 << (led - 1) for ring in expected_rings for led in ring)
        wait_until(lambda: twin.rings()[0] == word)
        expected = [[_last_colour(key, calls)] * 2 for key in keys]
        wait_until(lambda: _shown(emulator, twin, keys) == expected)
        keypad.close()
    finally:
        emulator.stop()
        host_bus.shutdown()
        device_bus.shutdown()


def test_many_threads_light_a_j1939_keypad(channel: str) -> None:
    twin = KeypadTwin(protocol="j1939")
    device_bus, host_bus, emulator = _bench(channel, twin)
    try:
        keypad = Keypad(host_bus, protocol="j1939")
        calls = 100
        workers = _led_workers(keypad, range(1, 13), calls)
        workers += [_repeat(lambda n: keypad.set_brightness(n % 64), 100) for _ in range(2)]
        assert keypad.j1939 is not None
        link = keypad.j1939
        workers += [_repeat(lambda n: link.software_revision(2.0), 5) for _ in range(2)]
        assert _hammer(workers) == []
        expected = [[_last_colour(key, calls)] * 2 for key in range(1, 13)]
        wait_until(lambda: _shown(emulator, twin, range(1, 13), "keys") == expected,
                   timeout=10.0)
        keypad.close()
    finally:
        emulator.stop()
        host_bus.shutdown()
        device_bus.shutdown()
