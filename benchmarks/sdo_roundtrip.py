"""SDO round trips on one virtual bus: the blinkcan driver against a twin in the Emulator,
beside python-canopen's RemoteNode against its LocalNode, same object dictionary, same run.

Expedited reads (1000h) and 20-byte segmented uploads (a string object added for the benchmark
to the keypad table, so both servers hold it). Target (DESIGN.md): >= 1.0x the anchor, and
>= 85 % of a same-shape Notifier echo (the floor: no SDO work at all).
Also the latency from a key-state frame on the bus to the application's callback.
"""

from __future__ import annotations

import dataclasses
import statistics
import threading
import time
import uuid
from collections.abc import Callable

import can
import canopen

from blinkcan.devices import describe_keypad
from blinkcan.devices.model import DeviceDescription
from blinkcan.devices.objects import text, var
from blinkcan.formats.canopen_od import object_dictionary
from blinkcan.host import HostBus, Keypad
from blinkcan.runtime import Emulator
from blinkcan.twin.base import CanopenTwin
from blinkcan.twin.keypad import KeypadTwin

NODE = 0x15
TWENTY = "twenty bytes of text"  # 20 characters


def _description() -> DeviceDescription:
    base = describe_keypad()
    extra = var(0x2300, "Benchmark text", text(0, "benchmark_text", "Benchmark text", TWENTY))
    return dataclasses.replace(base, table=base.table.with_objects(extra))


def _timed(call: Callable[[], object], count: int) -> tuple[float, list[float]]:
    latencies = []
    start = time.perf_counter()
    for _ in range(count):
        begin = time.perf_counter()
        call()
        latencies.append(time.perf_counter() - begin)
    return count / (time.perf_counter() - start), latencies


def _summary(rate: float, latencies: list[float]) -> str:
    ordered = sorted(latencies)
    p99 = ordered[int(len(ordered) * 0.99)]
    return (f"{rate:>8,.0f}/s  p50 {statistics.median(ordered) * 1e6:5.0f} us  "
            f"p99 {p99 * 1e6:5.0f} us")


def measure(count: int, block: int = 250) -> dict[str, tuple[float, list[float]]]:
    """Both setups alive at once on two virtual channels, measured in alternating blocks so
    both see the same machine load."""
    description = _description()
    ours_channel, anchor_channel = f"rt-ours-{uuid.uuid4().hex}", f"rt-anchor-{uuid.uuid4().hex}"
    device_bus, host_bus = (can.Bus(interface="virtual", channel=ours_channel) for _ in range(2))
    server, client = canopen.Network(), canopen.Network()
    server.connect(interface="virtual", channel=anchor_channel)
    client.connect(interface="virtual", channel=anchor_channel)
    twin = CanopenTwin(description, NODE)
    totals: dict[str, list[float]] = {}
    latencies: dict[str, list[float]] = {}
    try:
        with Emulator(device_bus, [twin]), HostBus(host_bus) as host:
            sdo = host.sdo(NODE)
            server.add_node(canopen.LocalNode(NODE, object_dictionary(description, NODE)))
            remote = canopen.RemoteNode(NODE, object_dictionary(description, NODE))
            client.add_node(remote)
            calls = {
                "ours expedited": lambda: sdo.upload(0x1000, 0),
                "anchor expedited": lambda: remote.sdo.upload(0x1000, 0),
                "ours segmented": lambda: sdo.upload(0x2300, 0),
                "anchor segmented": lambda: remote.sdo.upload(0x2300, 0),
            }
            assert sdo.upload(0x2300, 0) == remote.sdo.upload(0x2300, 0) == TWENTY.encode()
            for _ in range(max(1, count // block)):
                for name, call in calls.items():
                    n = block if "expedited" in name else block // 2
                    rate, lat = _timed(call, n)
                    totals.setdefault(name, []).append(n / rate)
                    latencies.setdefault(name, []).extend(lat)
    finally:
        client.disconnect()
        server.disconnect()
        device_bus.shutdown()
        host_bus.shutdown()
    return {name: (len(latencies[name]) / sum(totals[name]), latencies[name]) for name in totals}


def transport_floor(count: int) -> float:
    """Round trips/s of a bare echo of the same shape as ours, with no SDO work: the server
    side answers from a python-can Notifier's callback (the Emulator handles a frame on its
    Notifier's thread, runtime/emulator.py), the caller sends and waits through a Notifier and
    an Event (as both SDO clients do). A floor: any SDO server and client pay at least this."""
    channel = f"floor-{uuid.uuid4().hex}"
    caller, echo = (can.Bus(interface="virtual", channel=channel) for _ in range(2))
    arrived = threading.Event()

    class Echo(can.Listener):
        def on_message_received(self, msg: can.Message) -> None:
            echo.send(can.Message(arbitration_id=0x595, data=msg.data, is_extended_id=False))

    class Waker(can.Listener):
        def on_message_received(self, msg: can.Message) -> None:
            arrived.set()

    echo_notifier = can.Notifier(echo, [Echo()], timeout=0.1)
    notifier = can.Notifier(caller, [Waker()], timeout=0.1)
    request = can.Message(arbitration_id=0x615, data=bytes(8), is_extended_id=False)
    start = time.perf_counter()
    for _ in range(count):
        arrived.clear()
        caller.send(request)
        arrived.wait(1)
    rate = count / (time.perf_counter() - start)
    notifier.stop()
    echo_notifier.stop()
    caller.shutdown()
    echo.shutdown()
    return rate


def key_latency(presses: int) -> list[float]:
    """Seconds from the key-state frame on the bus to the Keypad driver's callback."""
    channel = f"keys-{uuid.uuid4().hex}"
    device_bus, host_bus = (can.Bus(interface="virtual", channel=channel) for _ in range(2))
    twin = KeypadTwin()
    sent: list[float] = []
    seen: list[float] = []
    done = threading.Event()
    with Emulator(device_bus, [twin]) as emulator, HostBus(host_bus) as host:
        emulator.on_frame = lambda frame, out, now: sent.append(time.perf_counter()) if (
            out and frame.can_id == 0x195) else None
        keypad = Keypad(host)
        time.sleep(0.05)

        def callback(event: object) -> None:
            seen.append(time.perf_counter())
            if len(seen) >= 2 * presses:
                done.set()

        keypad.on_key(callback)
        for _ in range(presses):
            emulator.press(twin, 1)
            emulator.release(twin, 1)
            time.sleep(0.001)
        done.wait(5)
    device_bus.shutdown()
    host_bus.shutdown()
    return [b - a for a, b in zip(sent, seen, strict=False)]


def main(smoke: bool = False) -> None:
    count = 300 if smoke else 5000
    results = measure(count)
    print("SDO round trips on a virtual bus (target >= 1.0x the anchor)")
    for kind in ("expedited", "segmented"):
        ours, anchor = results[f"ours {kind}"], results[f"anchor {kind}"]
        label = "expedited 1000h" if kind == "expedited" else "20-byte segmented"
        print(f"  {label:<18} blinkcan {_summary(*ours)}")
        print(f"  {'':<18} canopen  {_summary(*anchor)}   ratio {ours[0] / anchor[0]:.2f}x")
    floor = transport_floor(count)
    expedited = results["ours expedited"][0]
    print(f"  floor (a same-shape Notifier echo, no SDO): {floor:,.0f}/s; blinkcan reaches "
          f"{expedited / floor:.0%} of it (target >= 85 %), python-canopen "
          f"{results['anchor expedited'][0] / floor:.0%}")
    latencies = sorted(key_latency(50 if smoke else 500))
    if latencies:
        print(f"  key-state frame to callback: p50 {statistics.median(latencies) * 1e6:.0f} us, "
              f"p99 {latencies[int(len(latencies) * 0.99)] * 1e6:.0f} us")
