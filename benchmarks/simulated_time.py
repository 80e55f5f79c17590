"""Simulated time against real time: how much faster than the wall clock a rig runs.

Workload (DESIGN.md): a keypad and a Keybox, each with a 10 ms heartbeat and a 10 ms periodic
PDO (keypad: key state 1800h/05; Keybox: fault PDO 2012h), a controller whose drivers toggle an
output and read the states every 100 ms and set an LED, for 60 virtual seconds. The anchor is
real time itself (1x: the same minute on the wall clock). Also measured: the wall time of a
watchdog test and of a long-press test, and whether 20 runs give byte-identical frames.
"""

from __future__ import annotations

import statistics
import time

from blinkcan.host import Keybox, Keypad
from blinkcan.testing import Rig, TimedFrame
from blinkcan.twin import KeyboxTwin, KeypadTwin


def _minute(seconds: float) -> tuple[float, int, list[TimedFrame]]:
    start = time.perf_counter()
    with Rig() as rig:
        keypad_twin = rig.add(KeypadTwin(node_id=0x15, settings={
            "producer_heartbeat_time": 10, "tpdo1_event_timer": 10, "startup_led_show": 0}))
        keybox_twin = rig.add(KeyboxTwin(node_id=0x0C, settings={
            "producer_heartbeat_time": 10, "fault_period": 1}))
        keypad, keybox = Keypad(rig.bus, 0x15), Keybox(rig.bus, 0x0C, watchdog=0.1)
        keybox.set_fault_period(0.01)
        pin, key = 1, 1
        end = rig.now + seconds
        while rig.now < end:
            keybox.on(pin) if keybox_twin.snapshot()["pins"][pin - 1]["state"] == "off" \
                else keybox.off(pin)
            keybox.states()
            keypad.set_led(key, "green" if key % 2 else "red")
            pin, key = pin % 13 + 1, key % 12 + 1
            rig.advance(0.1)
        frames = list(rig.frames)
        keypad_twin.snapshot()
        keypad.close()
        keybox.close()
    return time.perf_counter() - start, len(frames), frames


def _watchdog_test() -> float:
    start = time.perf_counter()
    with Rig() as rig:
        twin = rig.add(KeyboxTwin(node_id=0x0C))
        keybox = Keybox(rig.bus, 0x0C, watchdog=0.1)
        keybox.on(4)
        rig.advance(0.5)
        keybox.stop_host_heartbeat()
        rig.until(lambda: twin.snapshot()["pins"][3]["state"] == "off", timeout=1.0)
        keybox.close()
    return time.perf_counter() - start


def _long_press_test() -> float:
    start = time.perf_counter()
    with Rig() as rig:
        twin = rig.add(KeypadTwin(node_id=0x15))
        keypad = Keypad(rig.bus, 0x15)
        rig.settle()  # the NMT start reaches the keypad
        events = keypad.events(timeout=2.0)
        rig.long_press(twin, 5, hold=1.0)
        assert [next(events).action for _ in range(3)] == ["press", "long press", "release"]
        keypad.close()
    return time.perf_counter() - start


def main(smoke: bool = False) -> None:
    seconds = 2.0 if smoke else 60.0
    runs = 1 if smoke else 3
    walls = []
    for _ in range(runs):
        wall, count, _frames = _minute(seconds)
        walls.append(wall)
    wall = statistics.median(walls)
    print(f"simulated time: {seconds:.0f} virtual s, {count} frames, wall {wall:.3f} s "
          f"(runs {', '.join(f'{w:.3f}' for w in walls)}): {seconds / wall:.0f}x real time "
          "(target >= 100x)")
    watchdog = statistics.median(_watchdog_test() for _ in range(5))
    long_press = statistics.median(_long_press_test() for _ in range(5))
    print(f"simulated time: watchdog test {watchdog * 1000:.1f} ms, long-press test "
          f"{long_press * 1000:.1f} ms wall (target < 50 ms each)")
    repeats = 3 if smoke else 20
    reference = _minute(1.0)[2]
    identical = all(_minute(1.0)[2] == reference for _ in range(repeats - 1))
    print(f"simulated time: {repeats} runs of the same scenario byte-identical "
          f"(times included): {identical}")
