"""Fleet logs to Parquet, frames per second per core: ``blinkcan decode LOG --parquet OUT``
beside what a user would write instead: python-can's LogReader + cantools ``decode_message``
(our DBC files for every device of the log, the J1939 one included) + pyarrow writing the same
table: a row for every frame, those no DBC knows (found by one dictionary lookup, as ours finds
them by its id route) as undecoded rows with their raw data, like ours; the same columns and
types, Hive-partitioned by model and date, row groups of 64k rows. (Ours writes more rows: a
frame that presses two keys is two rows.) Both run as their own process, interpreter start
included, on the realistic log of ``realistic_log.py`` (the devices' traffic from the twins
a third, other ECUs' 11-bit and 29-bit J1939 frames a third each). "Per core" is frames per
CPU second of the process (user + system), also shown as microseconds of CPU per frame.
Repetitions are interleaved; medians with ranges. Target (DESIGN.md): >= 3x.

Then the scaling: 4 such files decoded by 2 local workers (``-j 2``) against 1, wall time and
the CPU time of all processes (a -j 2 run that takes as much CPU as -j 1 but less than half
the speed-up is short of cores, not of parallelism: the load average is printed beside), and
from both figures an estimate of a 1,000-file fleet day on a 64-core cluster.
"""

from __future__ import annotations

import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from benchmarks.realistic_log import (
    device_nodes,
    device_options,
    realistic_traffic,
    write_candump,
)

ANCHOR = r"""
import datetime, json, sys
import can, cantools
import pyarrow as pa, pyarrow.parquet as pq
from blinkcan.devices.registry import describe_device
from blinkcan.formats import dbc, dbc_j1939
from blinkcan.fleet.schema import SCHEMA

source, out, devices = sys.argv[1], sys.argv[2], json.loads(sys.argv[3])
known = {}  # (frame id, extended) -> (cantools message, model): unknown ids skipped by lookup
for node, name in devices.items():
    description, node = describe_device(name), int(node)
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
            "-j", str(jobs), "--force", *device_options()]


def _micros(per_second: list[float]) -> str:
    """Microseconds of CPU per frame, median (range)."""
    values = [1e6 / v for v in per_second]
    return f"{statistics.median(values):5.1f} us/frame ({min(values):.1f}-{max(values):.1f})"


def _load() -> str:
    one, five, _ = os.getloadavg()
    return f"load average {one:.1f} (5 min {five:.1f}) on {os.cpu_count()} cores"


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
        devices = json.dumps(device_nodes())
        ours, anchor = [], []
        for repeat in range(repeats):  # interleaved
            _, cpu = _run(_ours([log], root / f"ours-{repeat}"))
            ours.append(frames / cpu)
            _, cpu = _run([sys.executable, "-c", ANCHOR, str(log), str(root / f"anchor-{repeat}"),
                           devices])
            anchor.append(frames / cpu)
        print(f"fleet decode to Parquet: a {frames:,}-frame realistic candump log, frames per "
              "CPU second, end to end (target >= 3x)")
        print(f"  blinkcan decode --parquet                {_spread(ours)}  {_micros(ours)}")
        print(f"  LogReader + cantools + pyarrow (anchor)  {_spread(anchor)}  "
              f"{_micros(anchor)}")
        ratios = [o / a for o, a in zip(ours, anchor, strict=True)]
        print(f"  ratio {statistics.median(ratios):.2f}x ({min(ratios):.2f}-{max(ratios):.2f})")

        files = 4
        logs = [root / f"unit-{n}.log" for n in range(files)]
        for path in logs:
            os.link(log, path)
        one, two, one_cpu, two_cpu = [], [], [], []
        before = _load()
        for repeat in range(repeats):
            wall, cpu = _run(_ours(logs, root / f"one-{repeat}", 1))
            one.append(wall)
            one_cpu.append(cpu)
            wall, cpu = _run(_ours(logs, root / f"two-{repeat}", 2))
            two.append(wall)
            two_cpu.append(cpu)
        speedup = [a / b for a, b in zip(one, two, strict=True)]
        per_core = statistics.median(ours)
        print(f"scaling: {files} such files, wall time, -j 1 against -j 2 (target >= 1.7x); "
              f"{before} before, {_load()} after")
        print(f"  1 worker  {statistics.median(one):6.1f} s   2 workers "
              f"{statistics.median(two):6.1f} s   speed-up {statistics.median(speedup):.2f}x "
              f"({min(speedup):.2f}-{max(speedup):.2f})")
        print(f"  CPU of all processes: -j 1 {statistics.median(one_cpu):.1f} s, -j 2 "
              f"{statistics.median(two_cpu):.1f} s; cores kept busy (CPU/wall): "
              f"{statistics.median(one_cpu) / statistics.median(one):.2f} and "
              f"{statistics.median(two_cpu) / statistics.median(two):.2f}")
        efficiency = min(statistics.median(speedup) / 2, 1.0)
        day_frames = 1_000 * 1_000_000  # 1,000 files of 1 M frames: a unit's day at ~30 frames/s
        print(f"  estimate: a fleet day of 1,000 files of 1 M frames each on 64 cores at "
              f"{per_core:,.0f} frames/s per core: {_minutes(day_frames, per_core * 64)} with "
              f"every core busy, {_minutes(day_frames, per_core * 64 * efficiency)} at the "
              f"{efficiency:.0%} scaling measured here")
