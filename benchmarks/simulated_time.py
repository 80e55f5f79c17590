"""Simulated time against real time: how much faster than the wall clock a rig runs.

The target scenario (DESIGN.md): a saturated 250 kbit/s bus, 14 Keyboxes each with a 10 ms
heartbeat and a 10 ms fault PDO (~2,800 frames/s), in a :class:`Rig` (the wire records every
frame, the controller's endpoint receives every frame), against real time and against a minimal
heap-based event loop running the same twins (their deadlines on a heap, each frame handed to the
twins listening to its COB-ID and recorded): what the simulation costs beyond the twins' own
work. Ours and the loop alternate; frames per wall-second, median (range). Target: >= 100x real
time and >= 50 % of the loop. The loop finds a frame's listeners through a COB-ID index rebuilt
when a twin's routes change, as the emulator does (until issue 22 it asked every twin about every
frame, which made it ~40 % slower and the ratio look better than it is). Each run starts with
the garbage of the runs before collected, so no run pays for another's.

The second scenario, lighter: a keypad and a Keybox, each with a 10 ms heartbeat and a 10 ms
periodic PDO (keypad: key state 1800h/05; Keybox: fault PDO 2012h), a controller whose drivers
toggle an output and read the states every 100 ms and set an LED, for 60 virtual seconds. The
anchor is real time itself (1x: the same minute on the wall clock). Also measured: the wall time of
a watchdog test and of a long-press test, and whether 20 runs give byte-identical frames.
"""

from __future__ import annotations

import collections
import gc
import heapq
import itertools
import os
import statistics
import time

from benchmarks.measure import interleaved, spread
from blinkcan.host import Keybox, Keypad
from blinkcan.protocol import Frame
from blinkcan.testing import Rig, TimedFrame
from blinkcan.twin import KeyboxTwin, KeypadTwin

KEYBOXES = 14
SATURATING = {"producer_heartbeat_time": 10, "fault_period": 1, "active_on_startup": 1}


def _keyboxes() -> list[KeyboxTwin]:
    return [KeyboxTwin(node_id=node, settings=SATURATING) for node in range(1, KEYBOXES + 1)]


def _collected() -> tuple[float, float]:
    """The clocks at the start of a run, once the garbage of the runs before is collected: a
    run's own collections count, the ones the previous run's objects would set off do not
    (the loop's record, a tuple per frame, had the next Rig run pay for a full pass)."""
    gc.collect()
    return time.perf_counter(), time.process_time()


def _saturated_rig(seconds: float) -> tuple[float, float, int]:
    """Wall and CPU seconds and frames of ``seconds`` virtual seconds of the saturated bus in a
    Rig."""
    start, cpu = _collected()
    with Rig() as rig:
        for twin in _keyboxes():
            rig.add(twin)
        rig.advance(seconds)
        count = len(rig.frames)
    return time.perf_counter() - start, time.process_time() - cpu, count


def _saturated_heap_loop(seconds: float) -> tuple[float, float, int]:
    """The same twins in a minimal event loop: deadlines on a heap, each frame recorded and
    handed to the twins listening to its COB-ID (an index rebuilt when a twin's routes change,
    as the emulator's; the other twins are not asked), their replies queued after it."""
    start, cpu = _collected()
    twins = _keyboxes()
    recorded: list[tuple[float, Frame]] = []
    sequence = itertools.count()
    heap: list[tuple[float, int, int]] = []
    deadlines: list[float | None] = [None] * len(twins)
    routes: list[object] = [None] * len(twins)
    index: dict[int, list[int]] = {}
    pending: collections.deque[tuple[int, Frame]] = collections.deque()

    def reindex() -> None:
        index.clear()
        for j, twin in enumerate(twins):
            routes[j] = twin.listening
            for can_id in twin.listening:
                index.setdefault(can_id, []).append(j)

    def called(i: int) -> None:
        """After a call into twin ``i``: its routes, and its deadline on the heap."""
        twin = twins[i]
        if twin.listening is not routes[i]:
            reindex()
        deadline = twin.next_deadline()
        if deadline != deadlines[i]:
            deadlines[i] = deadline
            if deadline is not None:
                heapq.heappush(heap, (deadline, next(sequence), i))

    def send(source: int, frames: list[Frame], now: float) -> None:
        pending.extend([(source, frame) for frame in frames])
        while pending:
            sender, frame = pending.popleft()
            recorded.append((now, frame))
            for j in range(len(twins)) if frame.extended else index.get(frame.can_id, ()):
                if j != sender:
                    replies = twins[j].receive(frame, now)
                    called(j)
                    pending.extend([(j, reply) for reply in replies])

    for i, twin in enumerate(twins):
        frames = twin.power_on(0.0)
        called(i)
        send(i, frames, 0.0)
    while heap and heap[0][0] <= seconds:
        due, _, i = heapq.heappop(heap)
        if deadlines[i] != due:
            continue  # moved since: a later entry stands for it
        deadlines[i] = None
        frames = twins[i].advance(due)
        called(i)
        send(i, frames, due)
    return time.perf_counter() - start, time.process_time() - cpu, len(recorded)


def saturated(seconds: float, repeats: int) -> None:
    load = os.getloadavg()[0]
    runs = interleaved({"ours": lambda: _saturated_rig(seconds),
                        "loop": lambda: _saturated_heap_loop(seconds)}, repeats)
    frames = runs["ours"][0][2]
    print(f"simulated time, saturated 250 kbit/s bus ({KEYBOXES} Keyboxes, 10 ms heartbeat + "
          f"10 ms fault PDO): {seconds:.0f} virtual s, {frames:,} frames "
          f"(the loop: {runs['loop'][0][2]:,}), median (range) of {repeats}; by the wall, and "
          "by CPU seconds (steadier on a shared machine); load average "
          f"{load:.1f} before, {os.getloadavg()[0]:.1f} after")
    for clock, what in ((0, "wall"), (1, "CPU")):
        ours = [run[clock] for run in runs["ours"]]
        loop = [run[clock] for run in runs["loop"]]
        print(f"  {what:<4} Rig        {spread([frames / t for t in ours])} frames/{what}-s, "
              f"{spread([seconds / t for t in ours])}x real time (target >= 100x)")
        print(f"       heap loop  {spread([frames / t for t in loop])} frames/{what}-s, "
              f"{spread([seconds / t for t in loop])}x real time")
        shares = [b / a for a, b in zip(ours, loop, strict=True)]
        print(f"       Rig / loop {spread(shares, 100, '.0f')} % (target >= 50 %)")


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
    saturated(2.0 if smoke else 20.0, 2 if smoke else 5)
    seconds = 2.0 if smoke else 60.0
    runs = 1 if smoke else 3
    walls = []
    for _ in range(runs):
        wall, count, _frames = _minute(seconds)
        walls.append(wall)
    wall = statistics.median(walls)
    print(f"simulated time: {seconds:.0f} virtual s, {count} frames, wall {wall:.3f} s "
          f"(runs {', '.join(f'{w:.3f}' for w in walls)}): {seconds / wall:.0f}x real time "
          f"({count / wall:,.0f} frames/wall-s)")
    watchdog = statistics.median(_watchdog_test() for _ in range(5))
    long_press = statistics.median(_long_press_test() for _ in range(5))
    print(f"simulated time: watchdog test {watchdog * 1000:.1f} ms, long-press test "
          f"{long_press * 1000:.1f} ms wall (target < 50 ms each)")
    repeats = 3 if smoke else 20
    reference = _minute(1.0)[2]
    identical = all(_minute(1.0)[2] == reference for _ in range(repeats - 1))
    print(f"simulated time: {repeats} runs of the same scenario byte-identical "
          f"(times included): {identical}")
