"""A python-canopen controller in simulated time (issue 24): how much faster than real time.

The scenario of the Rig benchmark's minute (``benchmarks/simulated_time.py``): a keypad and a
Keybox, each with a 10 ms heartbeat and a 10 ms periodic PDO (keypad: key state; Keybox: fault
PDO), for 60 virtual seconds, but driven by a python-canopen controller instead of blinkcan's
drivers: ``canopen.Network(rig.bus).connect()``, ``RemoteNode``s from our EDS, and every 100 ms
an SDO write toggling an output, an SDO read of an output's state and an LED RPDO. The anchor
is real time itself (1x: the same minute on the wall clock); beside it, the Rig benchmark's
own minute (blinkcan's drivers), measured interleaved in the same run, and CPU seconds (steadier
than wall time on a loaded machine). Target: >= 100x real time.

Also measured: whether 20 runs give byte-identical frames (times included), and what a
python-canopen SDO timeout costs: its configured ``RESPONSE_TIMEOUT`` in virtual time on the
rig, against the same timeout on python-can's ``virtual`` bus (real time, the anchor).
"""

from __future__ import annotations

import contextlib
import statistics
import time
import uuid
from typing import Any

import can
import canopen
from canopen.sdo.client import SdoClient
from canopen.sdo.exceptions import SdoCommunicationError

from benchmarks import simulated_time
from benchmarks.measure import interleaved, spread
from blinkcan.devices.registry import describe_device
from blinkcan.formats.shipped import shipped_eds
from blinkcan.testing import Rig, TimedFrame
from blinkcan.twin import KeyboxTwin, KeypadTwin

KEYPAD_EDS = str(shipped_eds(describe_device("keypad")))
KEYBOX_EDS = str(shipped_eds(describe_device("keybox")))


def _timed(run: Any) -> tuple[float, float, int]:
    """(wall seconds, CPU seconds, frames) of ``run()``."""
    wall, cpu = time.perf_counter(), time.process_time()
    count = run()[1]
    return time.perf_counter() - wall, time.process_time() - cpu, count


def _minute(seconds: float) -> tuple[float, int, list[TimedFrame]]:
    """Wall seconds, frames and the frames of ``seconds`` virtual seconds of the scenario."""
    start = time.perf_counter()
    with Rig() as rig:
        rig.add(KeypadTwin(node_id=0x15, settings={
            "producer_heartbeat_time": 10, "tpdo1_event_timer": 10, "startup_led_show": 0}))
        keybox_twin = rig.add(KeyboxTwin(node_id=0x0C, settings={
            "producer_heartbeat_time": 10, "fault_period": 1}))
        network = canopen.Network(rig.bus)
        network.connect()
        keypad: Any = network.add_node(0x15, KEYPAD_EDS)
        keybox: Any = network.add_node(0x0C, KEYBOX_EDS)
        keypad.rpdo.read()
        keybox.tpdo.read()
        heard: list[int] = []
        keybox.tpdo[1].add_callback(lambda pdo: heard.append(1))
        keypad.nmt.state = "OPERATIONAL"
        keybox.nmt.state = "OPERATIONAL"
        leds = keypad.rpdo[1]
        pin, key = 1, 1
        end = rig.now + seconds
        while rig.now < end:
            high = keybox_twin.snapshot()["pins"][pin - 1]["state"] == "high"
            keybox.sdo["Single pin state"][pin].raw = 0 if high else 1
            keybox.sdo["Single pin state"][pin].raw  # noqa: B018 (the read is the load)
            leds[0].raw = 1 << (key % 8)
            leds.transmit()
            pin, key = pin % 13 + 1, key % 12 + 1
            rig.advance(0.1)
        frames = list(rig.frames)
        network.disconnect()
    return time.perf_counter() - start, len(frames), frames


def _sdo_timeout_on_the_rig() -> tuple[float, float]:
    """(virtual seconds, wall seconds) of one python-canopen SDO read nobody answers."""
    with Rig() as rig:
        network = canopen.Network(rig.bus)
        network.connect()
        node: Any = network.add_node(0x0C, KEYBOX_EDS)
        node.sdo.MAX_RETRIES = 1
        start_virtual, start_wall = rig.now, time.perf_counter()
        with contextlib.suppress(SdoCommunicationError):
            node.sdo[0x1000].raw  # noqa: B018
        taken = rig.now - start_virtual, time.perf_counter() - start_wall
        network.disconnect()
    return taken


def _sdo_timeout_in_real_time() -> float:
    """Wall seconds of the same read on python-can's virtual bus (the anchor)."""
    bus = can.Bus(interface="virtual", channel=f"blinkcan-bench-{uuid.uuid4().hex}")
    network = canopen.Network(bus)
    network.connect()
    node: Any = network.add_node(0x0C, KEYBOX_EDS)
    start = time.perf_counter()
    with contextlib.suppress(SdoCommunicationError):
        node.sdo[0x1000].raw  # noqa: B018
    taken = time.perf_counter() - start
    network.disconnect()
    return taken


def main(smoke: bool = False) -> None:
    seconds = 2.0 if smoke else 60.0
    runs = interleaved({"canopen": lambda: _timed(lambda: _minute(seconds)),
                        "drivers": lambda: _timed(lambda: simulated_time._minute(seconds))},
                       1 if smoke else 3)
    for name, label in (("canopen", "python-canopen controller"),
                        ("drivers", "blinkcan drivers (Rig benchmark)")):
        walls = [wall for wall, _, _ in runs[name]]
        cpus = [cpu for _, cpu, _ in runs[name]]
        print(f"{label}, simulated time: {seconds:.0f} virtual s, {runs[name][0][2]} frames: "
              f"{spread([seconds / w for w in walls])}x real time by wall clock, "
              f"{spread([seconds / c for c in cpus])}x by CPU time (target >= 100x; real time: "
              "1x)")
    repeats = 3 if smoke else 20
    reference = _minute(1.0)[2]
    identical = all(_minute(1.0)[2] == reference for _ in range(repeats - 1))
    print(f"python-canopen controller: {repeats} runs of the same scenario byte-identical "
          f"(times included): {identical}")
    timeouts = [_sdo_timeout_on_the_rig() for _ in range(3 if smoke else 5)]
    anchor = _sdo_timeout_in_real_time()
    virtual = statistics.median(v for v, _ in timeouts)
    walls = [w for _, w in timeouts]
    print(f"python-canopen SDO timeout (RESPONSE_TIMEOUT {SdoClient.RESPONSE_TIMEOUT}"
          f" s): {virtual:.3f} virtual s in {statistics.median(walls) * 1000:.1f} ms wall "
          f"(range {min(walls) * 1000:.1f}-{max(walls) * 1000:.1f}); on python-can's virtual "
          f"bus: {anchor * 1000:.0f} ms wall")
