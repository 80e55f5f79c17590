"""Fleet logs to Parquet, frames per second per core: ``blinkcan decode LOG --parquet OUT``
beside what a user would write instead: python-can's LogReader + cantools ``decode_message``
(our DBC files, unknown ids skipped by a set lookup) + pyarrow writing the same table (the same
columns, Hive-partitioned by model and date, row groups of 64k rows). Both run as their own
process, interpreter start included, on a realistic candump log: the twins' own traffic (a
PKP-2600-SI, a PKP-3500-MT, a Keybox and a J1939 keypad: heartbeats, key presses, the
controller's LED and output commands, a fuse blown now and then, SDO reads), plus other ECUs'
11-bit frames (a third) and 29-bit J1939 engine and vehicle frames (a third). "Per core" is
frames per CPU second of the process (user + system). Repetitions are interleaved; medians
with ranges. Target (DESIGN.md): >= 3x.

Then the scaling: the same files decoded by 2 local workers (``-j 2``) against 1, wall time,
and from both figures an estimate of a 1,000-file fleet day on a 64-core cluster.
"""

from __future__ import annotations

import os
import random
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from blinkcan.devices.registry import describe_device
from blinkcan.protocol import Frame
from blinkcan.protocol.cob import SDO_RX
from blinkcan.twin import KeyboxTwin, KeypadTwin

ANCHOR = r"""
import datetime, sys
import can, cantools
import pyarrow as pa, pyarrow.parquet as pq
from blinkcan.devices.registry import describe_device
from blinkcan.formats import dbc, dbc_j1939
from blinkcan.fleet.schema import SCHEMA

source, out = sys.argv[1], sys.argv[2]
known = {}  # (frame id, extended) -> (cantools message, model): unknown ids skipped by lookup
for name, node in (("keypad", 0x15), ("pkp-3500-mt", 0x16), ("keybox", 0x0C)):
    description = describe_device(name)
    for message in dbc.database(description, node).messages:
        known[message.frame_id, False] = (message, description.model)
for message in dbc_j1939.database().messages:
    known[message.frame_id, True] = (message, describe_device("keypad").model)
schema = SCHEMA.append(pa.field("model", pa.string())).append(pa.field("date", pa.string()))
rows, days = [], {}

def flush():
    columns = list(zip(*rows))
    arrays = [pa.array(values, type=field.type) for field, values in zip(schema, columns)]
    pq.write_to_dataset(pa.Table.from_arrays(arrays, schema=schema), out,
                        partition_cols=["model", "date"])
    rows.clear()

with can.LogReader(source) as reader:
    for msg in reader:
        ident, data = msg.arbitration_id, bytes(msg.data)
        day = int(msg.timestamp // 86400)
        date = days.get(day)
        if date is None:
            date = days[day] = datetime.date.fromordinal(719163 + day).isoformat()
        found = known.get((ident, msg.is_extended_id))
        if found is not None:
            message, model = found
            try:
                signals = message.decode(data, decode_choices=False)
                kind, text = message.name, str(signals)
            except Exception as error:
                kind, text = "undecoded", str(error)
            node = ident & 0xFF if msg.is_extended_id else ident & 0x7F
        else:
            kind, text, model, node = "undecoded", f"frame {ident:X}h", "unknown", None
        rows.append((round(msg.timestamp * 1e6), source, msg.channel, ident, msg.is_extended_id,
                     node, kind, None, None, None, None, None, text, data, model, date))
        if len(rows) >= 65536:
            flush()
if rows:
    flush()
"""

EPOCH = 1_780_000_000.0
#: the nodes of the log, told to both (the anchor's DBC files are made for them)
DEVICES = ("--device", "0x15=keypad", "--device", "0x16=pkp-3500-mt", "--device", "0x0C=keybox")
#: other ECUs: 11-bit ids of nodes that are none of ours, and J1939 engine and vehicle PGNs
FOREIGN_STANDARD = (0x181, 0x182, 0x281, 0x1A3, 0x2A3, 0x3A3, 0x4A3, 0x123, 0x456, 0x7E8)
FOREIGN_EXTENDED = (0x0CF00400, 0x0CF00300, 0x18FEF100, 0x18FEEE00, 0x18FEF200, 0x18FEE900,
                    0x18FEFC17, 0x18FEEF00, 0x0C000003, 0x18FECA00)


def realistic_traffic(frames: int, seed: int = 23) -> list[tuple[float, Frame]]:
    """The twins' traffic a third, other ECUs' 11-bit and 29-bit frames a third each."""
    chance = random.Random(seed)
    keypad, keybox = KeypadTwin(node_id=0x15), KeyboxTwin(node_id=0x0C)
    mt = KeypadTwin(node_id=0x16, model="pkp-3500-mt")
    j1939 = KeypadTwin(node_id=0x17, protocol="j1939")
    canopen = (keypad, mt, keybox)
    twins = (*canopen, j1939)
    log: list[tuple[float, Frame]] = []

    def send(frame: Frame, now: float) -> None:
        log.append((now, frame))
        for twin in twins:
            log.extend((now, reply) for reply in twin.receive(frame, now))

    for twin in twins:
        log.extend((0.0, f) for f in twin.power_on(0.0))
    send(Frame(0x000, bytes((0x01, 0x00))), 0.001)
    for twin in canopen:  # 1017h = 100 ms heartbeats
        send(Frame(SDO_RX + twin.node_id, bytes((0x2B, 0x17, 0x10, 0x00, 100, 0, 0, 0))), 0.002)
    led_on = describe_device("keypad").pdo("led_on")
    outputs = describe_device("keybox").pdo("outputs")
    readable = [(twin, entry) for twin in canopen for entry in twin.description.table
                if entry.access.readable and not entry.data_type.is_string]
    now = 0.01
    held: set[tuple[int, int]] = set()
    while len(log) < frames:
        now += 0.01
        for twin in twins:
            log.extend((now, f) for f in twin.advance(now))
        roll = chance.random()
        if roll < 0.05:  # a key pressed or released on a keypad, the controller answers
            key = chance.randint(1, 12)
            twin = chance.choice((keypad, j1939))
            step = twin.release if (twin.node_id, key) in held else twin.press
            held ^= {(twin.node_id, key)}
            log.extend((now, f) for f in step(key, now))
            send(Frame(led_on.cob_id(0x15), led_on.encode({"red": chance.getrandbits(12),
                                                             "green": 0, "blue": 0})), now)
            send(Frame(outputs.cob_id(0x0C), outputs.encode(
                {"off": 0, "high": chance.getrandbits(13)})), now)
        elif roll < 0.06:
            twin, entry = chance.choice(readable)
            send(Frame(SDO_RX + twin.node_id, bytes((0x40,)) + entry.mux + bytes(4)), now)
        elif roll < 0.062:
            pin = chance.randint(1, 11)
            log.extend((now, f) for f in (keybox.blow_fuse if chance.random() < 0.5
                                          else keybox.replace_fuse)(pin, now))
        # other ECUs: about as many 11-bit and 29-bit frames each as the devices send
        if chance.random() < 0.7:
            log.append((now, Frame(chance.choice(FOREIGN_STANDARD), chance.randbytes(8))))
        if chance.random() < 0.7:
            log.append((now, Frame(chance.choice(FOREIGN_EXTENDED), chance.randbytes(8), True)))
    return log[:frames]


def write_candump(path: Path, traffic: list[tuple[float, Frame]]) -> None:
    with path.open("w") as stream:
        for time_s, frame in traffic:
            ident = f"{frame.can_id:08X}" if frame.extended else f"{frame.can_id:03X}"
            stream.write(f"({EPOCH + time_s:.6f}) can0 {ident}#{frame.data.hex().upper()}\n")


def _run(arguments: list[str]) -> tuple[float, float]:
    """(wall seconds, CPU seconds of the child)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    subprocess.run(arguments, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def _ours(logs: list[Path], out: Path, jobs: int = 1) -> list[str]:
    return [sys.executable, "-m", "blinkcan", "decode", *map(str, logs), "--parquet", str(out),
            "-j", str(jobs), "--force", *DEVICES]


def _spread(values: list[float]) -> str:
    return f"{statistics.median(values):>10,.0f} ({min(values):,.0f}-{max(values):,.0f})"


def _minutes(frames: float, per_second: float) -> str:
    return f"{frames / per_second / 60:,.0f} min"


def main(smoke: bool = False) -> None:
    frames = 20_000 if smoke else 300_000
    repeats = 1 if smoke else 3
    with tempfile.TemporaryDirectory() as folder:
        root = Path(folder)
        log = root / "unit.log"
        traffic = realistic_traffic(frames)
        write_candump(log, traffic)
        foreign = sum(1 for _, f in traffic if f.can_id in (
            FOREIGN_EXTENDED if f.extended else FOREIGN_STANDARD))
        ours, anchor = [], []
        for repeat in range(repeats):  # interleaved
            _, cpu = _run(_ours([log], root / f"ours-{repeat}"))
            ours.append(frames / cpu)
            _, cpu = _run([sys.executable, "-c", ANCHOR, str(log), str(root / f"anchor-{repeat}")])
            anchor.append(frames / cpu)
        print(f"fleet decode to Parquet: a {frames:,}-frame candump log ({foreign / frames:.0%} "
              "other ECUs' frames), frames per CPU second, end to end (target >= 3x)")
        print(f"  blinkcan decode --parquet                       {_spread(ours)}")
        print(f"  LogReader + cantools + pyarrow (anchor)         {_spread(anchor)}")
        ratios = [o / a for o, a in zip(ours, anchor, strict=True)]
        print(f"  ratio {statistics.median(ratios):.2f}x ({min(ratios):.2f}-{max(ratios):.2f})")

        files = 4
        logs = [root / f"unit-{n}.log" for n in range(files)]
        for path in logs:
            os.link(log, path)
        one, two = [], []
        for repeat in range(repeats):
            one.append(_run(_ours(logs, root / f"one-{repeat}", 1))[0])
            two.append(_run(_ours(logs, root / f"two-{repeat}", 2))[0])
        speedup = [a / b for a, b in zip(one, two, strict=True)]
        per_core = statistics.median(ours)
        print(f"scaling: {files} such files, wall time, -j 1 against -j 2 (target >= 1.7x)")
        print(f"  1 worker  {statistics.median(one):6.1f} s   2 workers "
              f"{statistics.median(two):6.1f} s   speed-up {statistics.median(speedup):.2f}x "
              f"({min(speedup):.2f}-{max(speedup):.2f})")
        efficiency = min(statistics.median(speedup) / 2, 1.0)
        day_frames = 1_000 * 1_000_000  # 1,000 files of 1 M frames: a unit's day at ~30 frames/s
        print(f"  estimate: a fleet day of 1,000 files of 1 M frames each on 64 cores at "
              f"{per_core:,.0f} frames/s per core: {_minutes(day_frames, per_core * 64)} with "
              f"every core busy, {_minutes(day_frames, per_core * 64 * efficiency)} at the "
              f"{efficiency:.0%} scaling measured here")
