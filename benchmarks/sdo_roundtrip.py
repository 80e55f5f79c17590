"""SDO round trips: the blinkcan driver (HostBus) against a twin in the Emulator, beside
python-canopen's RemoteNode against its LocalNode, same object dictionary, same run; in one
process on python-can's virtual bus, and across processes on udp_multicast (hop limit 0: the
servers in a child process).

Expedited reads (1000h) and 20-byte segmented uploads (a string object added for the benchmark
to the keypad table, so both servers hold it). The floor is a same-shape echo: a Notifier
callback answers, a Notifier wakes the caller through an Event, no SDO work at all. The three
run in alternating blocks, so all see the same machine load; figures are round trips per CPU
second of the processes involved (the machine is shared; wall figures printed after), medians
with ranges over the blocks. Targets (DESIGN.md): >= 1.0x the anchor, >= 85 % of the floor.
Also the latency from a key-state frame on the bus to the application's callback.
"""

from __future__ import annotations

import contextlib
import dataclasses
import os
import random
import statistics
import subprocess
import sys
import threading
import time
import uuid
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import can
import canopen

from benchmarks.measure import ratio_text, ratios, spread
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


class _Echo(can.Listener):
    """The floor's server side: answers a request from the Notifier's callback, as the
    Emulator answers from its reader's thread (runtime/scheduler.py ``deliver``)."""

    def __init__(self, bus: can.BusABC, lean: bool = False) -> None:
        self.bus = bus
        self.lean = lean

    def on_message_received(self, msg: can.Message) -> None:
        if msg.arbitration_id == 0x600 + NODE:  # not its own echoed reply (udp_multicast)
            reply = can.Message(arbitration_id=0x580 + NODE, data=msg.data,
                                is_extended_id=False)
            if self.lean:
                reply.data = bytes(msg.data)  # type: ignore[assignment]  # see _floor_call
            self.bus.send(reply)


class _Waker(can.Listener):
    """The floor's client side: a Notifier wakes the caller through an Event, as both SDO
    clients do."""

    def __init__(self) -> None:
        self.arrived = threading.Event()

    def on_message_received(self, msg: can.Message) -> None:
        if msg.arbitration_id == 0x580 + NODE:  # not its own echoed request (udp_multicast)
            self.arrived.set()


def _floor_call(bus: can.BusABC, lean: bool = False
                ) -> tuple[Callable[[], object], Callable[[], None]]:
    """A same-shape echo round trip with no SDO work: the floor any SDO pair pays.

    ``lean``: both sides send Messages whose data are ``bytes``, as blinkcan's port does on the
    buses that reuse a Message. python-can's constructor makes a ``bytearray``, and the virtual
    bus deep-copies every Message it sends: a bytearray goes through copy's reduce protocol,
    bytes are taken as they are. The echo as a user writes it pays that copy twice per round
    trip and blinkcan does not, so the one-process figure is also printed against the lean
    echo: the cheapest same-shape round trip this bus has."""
    waker = _Waker()
    notifier = can.Notifier(bus, [waker], timeout=0.1)
    request = can.Message(arbitration_id=0x600 + NODE, data=bytes(8), is_extended_id=False)
    if lean:
        request.data = bytes(8)  # type: ignore[assignment]

    def call() -> None:
        waker.arrived.clear()
        bus.send(request)
        waker.arrived.wait(1)

    return call, notifier.stop


def _servers(description: DeviceDescription, ours: can.BusABC, anchor: canopen.Network,
             floor: can.BusABC, lean_floor: can.BusABC | None = None) -> contextlib.ExitStack:
    """The server sides: our twin in the Emulator, python-canopen's LocalNode, the echo (and
    the lean echo, see ``_floor_call``). Closed with the returned stack."""
    stack = contextlib.ExitStack()
    stack.enter_context(Emulator(ours, [CanopenTwin(description, NODE)]))
    anchor.add_node(canopen.LocalNode(NODE, object_dictionary(description, NODE)))
    stack.callback(can.Notifier(floor, [_Echo(floor)], timeout=0.1).stop)
    if lean_floor is not None:
        stack.callback(can.Notifier(lean_floor, [_Echo(lean_floor, lean=True)],
                                    timeout=0.1).stop)
    return stack


#: a measure: name -> (round trips, CPU seconds, wall seconds), per block
Blocks = dict[str, list[tuple[int, float, float]]]


def _blocks(calls: dict[str, Callable[[], object]], count: int, block: int,
            other_cpu: Callable[[], float] = lambda: 0.0) -> Blocks:
    """Every call ``count`` times in blocks of ``block``, the setups alternating so that all
    see the same machine load; CPU is this process's plus ``other_cpu()`` (a server process)."""
    results: Blocks = {name: [] for name in calls}
    for _ in range(max(1, count // block)):
        for name, call in calls.items():
            n = block // 2 if "segmented" in name else block
            other, cpu, wall = other_cpu(), time.process_time(), time.perf_counter()
            for _ in range(n):
                call()
            wall = time.perf_counter() - wall
            cpu = time.process_time() - cpu + other_cpu() - other
            results[name].append((n, cpu, wall))
    return results


@contextlib.contextmanager
def _one_cpu() -> Iterator[str]:
    """The threads made inside on one CPU (Linux: they inherit the affinity of the thread that
    makes them). In one process the three setups' threads hand each frame to one another; the
    kernel puts them on one CPU in some blocks and spreads them in others, and spread they
    cost about twice the CPU per round trip, so the floor flipped between ~17 k and ~30 k/s
    from block to block and the ratios mixed regimes (session 9). Pinned, every block runs in
    the same regime. Says what was done, for the report."""
    if not hasattr(os, "sched_setaffinity"):
        yield "threads not pinned (no sched_setaffinity here)"
        return
    before = os.sched_getaffinity(0)
    os.sched_setaffinity(0, {min(before)})
    try:
        yield f"all its threads on CPU {min(before)}"
    finally:
        os.sched_setaffinity(0, before)


def in_one_process(count: int, block: int = 250) -> Blocks:
    """Ours, python-canopen's pair and the floor alive at once on three virtual channels."""
    with _one_cpu():
        return _in_one_process(count, block)


def _in_one_process(count: int, block: int) -> Blocks:
    description = _description()
    channels = [f"rt-{uuid.uuid4().hex}" for _ in range(4)]
    device_bus, host_bus = (can.Bus(interface="virtual", channel=channels[0]) for _ in range(2))
    server, client = canopen.Network(), canopen.Network()
    server.connect(interface="virtual", channel=channels[1])
    client.connect(interface="virtual", channel=channels[1])
    echo_bus, caller_bus = (can.Bus(interface="virtual", channel=channels[2]) for _ in range(2))
    lean_echo_bus, lean_caller_bus = (can.Bus(interface="virtual", channel=channels[3])
                                      for _ in range(2))
    floor, stop_floor = _floor_call(caller_bus)
    lean_floor, stop_lean_floor = _floor_call(lean_caller_bus, lean=True)
    try:
        with _servers(description, device_bus, server, echo_bus, lean_echo_bus), \
                HostBus(host_bus) as host:
            sdo = host.sdo(NODE)
            remote = canopen.RemoteNode(NODE, object_dictionary(description, NODE))
            client.add_node(remote)
            assert sdo.upload(0x2300, 0) == remote.sdo.upload(0x2300, 0) == TWENTY.encode()
            return _blocks({
                "ours expedited": lambda: sdo.upload(0x1000, 0),
                "anchor expedited": lambda: remote.sdo.upload(0x1000, 0),
                "floor": floor,
                "lean floor": lean_floor,
                "ours segmented": lambda: sdo.upload(0x2300, 0),
                "anchor segmented": lambda: remote.sdo.upload(0x2300, 0),
            }, count, block)
    finally:
        stop_floor()
        stop_lean_floor()
        client.disconnect()
        server.disconnect()
        for bus in (device_bus, host_bus, echo_bus, caller_bus, lean_echo_bus, lean_caller_bus):
            bus.shutdown()


def _multicast_kwargs(address: str) -> dict[str, Any]:
    group, port = address.split(":")
    return {"interface": "udp_multicast", "channel": group, "port": int(port), "hop_limit": 0}


def serve(ours: str, anchor: str, floor: str) -> None:
    """The server sides in a process of their own, on udp_multicast ``group:port`` addresses
    (hop limit 0: this machine only). Answers "cpu" on stdin with its CPU seconds; stops at
    the end of stdin."""
    description = _description()
    device_bus, echo_bus = can.Bus(**_multicast_kwargs(ours)), can.Bus(**_multicast_kwargs(floor))
    server = canopen.Network()
    server.connect(**_multicast_kwargs(anchor))
    try:
        with _servers(description, device_bus, server, echo_bus):
            print("ready", flush=True)
            for line in sys.stdin:
                if line.strip() != "cpu":
                    break
                print(time.process_time(), flush=True)
    finally:
        server.disconnect()
        device_bus.shutdown()
        echo_bus.shutdown()


def across_processes(count: int, block: int = 250) -> Blocks | None:
    """The same three pairs, each server in a child process on udp_multicast; CPU counts
    both processes. None where udp_multicast is not available."""
    addresses = [f"239.74.{random.randint(1, 254)}.{random.randint(1, 254)}:"
                 f"{random.randint(40000, 60000)}" for _ in range(3)]
    try:
        host_bus, caller_bus = (can.Bus(**_multicast_kwargs(addresses[i])) for i in (0, 2))
    except (OSError, ImportError, can.CanError):
        return None
    child = subprocess.Popen(
        [sys.executable, "-c", "import sys; from benchmarks.sdo_roundtrip import serve; "
         "serve(*sys.argv[1:])", *addresses],
        stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True,
        cwd=Path(__file__).resolve().parent.parent)
    assert child.stdin is not None
    assert child.stdout is not None
    stdin, stdout = child.stdin, child.stdout

    def child_cpu() -> float:
        stdin.write("cpu\n")
        stdin.flush()
        return float(stdout.readline())

    client = canopen.Network()
    floor, stop_floor = _floor_call(caller_bus)
    try:
        if stdout.readline().strip() != "ready":
            raise RuntimeError("the server process did not start")
        client.connect(**_multicast_kwargs(addresses[1]))
        description = _description()
        with HostBus(host_bus) as host:
            sdo = host.sdo(NODE)
            remote = canopen.RemoteNode(NODE, object_dictionary(description, NODE))
            client.add_node(remote)
            assert sdo.upload(0x1000, 0) == remote.sdo.upload(0x1000, 0)
            return _blocks({
                "ours expedited": lambda: sdo.upload(0x1000, 0),
                "anchor expedited": lambda: remote.sdo.upload(0x1000, 0),
                "floor": floor,
            }, count, block, child_cpu)
    finally:
        stop_floor()
        client.disconnect()
        stdin.close()
        try:
            child.wait(timeout=10)
        except subprocess.TimeoutExpired:
            child.kill()
        host_bus.shutdown()
        caller_bus.shutdown()


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


def _rates(blocks: list[tuple[int, float, float]], per: int) -> list[float]:
    """Round trips per CPU second (per=1) or per wall second (per=2), block by block."""
    return [block[0] / block[per] for block in blocks]


def _report(title: str, results: Blocks) -> None:
    print(f"  {title}: round trips per CPU second of the processes, median (range) of "
          f"{len(results['floor'])} interleaved blocks; per wall second after")
    floor = _rates(results["floor"], 1)
    for kind in ("expedited", "segmented"):
        if f"ours {kind}" not in results:
            continue
        ours, anchor = (_rates(results[f"{who} {kind}"], 1) for who in ("ours", "anchor"))
        label = "expedited 1000h" if kind == "expedited" else "20-byte segmented"
        print(f"    {label:<18} blinkcan {spread(ours):>24}/s  python-canopen "
              f"{spread(anchor):>24}/s  ratio {ratio_text(anchor, ours)} (target >= 1.0x)")
        print(f"    {'':<18} wall     {spread(_rates(results[f'ours {kind}'], 2)):>24}/s  "
              f"{'':<14} {spread(_rates(results[f'anchor {kind}'], 2)):>24}/s")
    ours, anchor = (_rates(results[f"{who} expedited"], 1) for who in ("ours", "anchor"))
    print(f"    floor (a same-shape Notifier echo, no SDO) {spread(floor)}/s: blinkcan "
          f"{spread(ratios(floor, ours), 100, '.0f')} % of it (target >= 85 %), "
          f"python-canopen {spread(ratios(floor, anchor), 100, '.0f')} %")
    if "lean floor" in results:
        lean = _rates(results["lean floor"], 1)
        print(f"    lean floor (the same echo sending bytes data: no slow copy on the virtual "
              f"bus, as blinkcan's port) {spread(lean)}/s: blinkcan "
              f"{spread(ratios(lean, ours), 100, '.0f')} % of it, python-canopen "
              f"{spread(ratios(lean, anchor), 100, '.0f')} %")


def main(smoke: bool = False) -> None:
    count = 300 if smoke else 6000
    print("SDO round trips: blinkcan (HostBus <-> twin in the Emulator) beside python-canopen "
          "(RemoteNode <-> LocalNode), same object dictionary, same run")
    _report("in one process (virtual bus, all its threads on one CPU: spread over two, the "
            "floor flips between two regimes from block to block)", in_one_process(count))
    across = across_processes(count)  # 24 blocks, as in one process: its ranges are wide
    if across is None:
        print("  across processes: udp_multicast is not available here (skipped)")
    else:
        _report("across processes (udp_multicast, hop limit 0)", across)
    latencies = sorted(key_latency(50 if smoke else 500))
    if latencies:
        print(f"  key-state frame to callback: p50 {statistics.median(latencies) * 1e6:.0f} us, "
              f"p99 {latencies[int(len(latencies) * 0.99)] * 1e6:.0f} us")
