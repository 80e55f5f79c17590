"""Fleet logs to Parquet, frames per second per core: ``blinkcan decode LOG --parquet OUT``
beside what a user would write instead: python-can's LogReader + cantools ``decode_message``
(our DBC files for every device of the log, the J1939 one included) + pyarrow writing the same
table: a row for every frame, those no DBC knows (found by one dictionary lookup, as ours finds
them by its id route) as undecoded rows with their raw data, like ours; the same columns and
types, Hive-partitioned by model and date, row groups of 64k rows. (Ours writes more rows: a
frame that presses two keys is two rows.) Both run as their own process, interpreter start
included, on the realistic 1 M-frame log of the speed issue (``realistic_log.py``, as
``decode_log.py``: the devices' traffic from the twins a third, other ECUs' 11-bit and 29-bit
J1939 frames a third each). "Per core" is frames per CPU second of the process (user +
system), also shown as microseconds of CPU per frame; then the same without each side's
start-up (the CPU of a run on the log's first 20 frames). Repetitions are interleaved;
medians with ranges. Target (DESIGN.md): >= 3x.

Then the scaling: 4 such files decoded by 2 local workers (``-j 2``) against 1, wall time and
the CPU time of all processes (a -j 2 run that takes as much CPU as -j 1 but less than half
the speed-up is short of cores, not of parallelism: the load average is printed beside), and
from both figures an estimate of a 1,000-file fleet day on a 64-core cluster.
"""

from __future__ import annotations

import json
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

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

schema = SCHEMA.append(pa.field("model", pa.string())).append(pa.field("date", pa.string()))
GROUP = 65536

def known_messages(devices):
    # (frame id, extended) -> (cantools message, model): unknown ids skipped by lookup
    known = {}
    for node, name in devices.items():
        description, node = describe_device(name), int(node)
        for message in dbc.database(description, node).messages:
            known[message.frame_id, False] = (message, description.model)
    for message in dbc_j1939.database().messages:
        known[message.frame_id, True] = (message, describe_device("keypad").model)
    return known

def flush(rows, out):
    columns = list(zip(*rows))
    arrays = [pa.array(values, type=field.type) for field, values in zip(schema, columns)]
    pq.write_to_dataset(pa.Table.from_arrays(arrays, schema=schema), out,
                        partition_cols=["model", "date"])
    rows.clear()

def decode(messages, source, known, group):
    # the rows of the messages, group(rows) called for every GROUP of them
    rows, days = [], {}
    for msg in messages:
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
        if len(rows) >= GROUP:
            group(rows)
    if rows:
        group(rows)

if __name__ == "__main__":
    source, out, devices = sys.argv[1], sys.argv[2], json.loads(sys.argv[3])
    known = known_messages(devices)
    with can.LogReader(source) as reader:
        decode(reader, source, known, lambda rows: flush(rows, out))
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


def _cpu(work: Callable[[], object]) -> float:
    """CPU seconds of this process for one run of ``work``."""
    start = time.process_time()
    work()
    return time.process_time() - start


def _our_stages(log: Path, out: Path) -> dict[str, Callable[[], object]]:
    """Our pipeline cut into its stages (in process): each re-runs the stages before it
    where it needs their output, the difference is taken afterwards."""
    from blinkcan.decode.decoder import Event
    from blinkcan.fleet.frames import FrameDecoder, Segment
    from blinkcan.fleet.local_files import LocalFiles
    from blinkcan.fleet.schema import ROWS_PER_GROUP
    from blinkcan.fleet.sources import read_columns
    from blinkcan.fleet.task import make_decoder
    from blinkcan.fleet.writer import PartitionWriter
    from blinkcan.protocol.frame import Frame

    blocks = list(read_columns(log))
    segments: list[Segment] = []
    # the frames the decoder decodes (those of other ECUs it has seen are filled in per
    # identifier: fleet/frames.py), recorded from one run, in order
    decoded: list[tuple[Frame, float]] = []
    recording = make_decoder(device_nodes())
    decode_one = recording.decode

    def record(frame: Frame, time: float = 0.0) -> Event:
        decoded.append((frame, time))
        return decode_one(frame, time)

    recording.decode = record  # type: ignore[method-assign]
    recorder, segment = FrameDecoder(recording), Segment()
    for block in blocks:
        position = 0
        while position < len(block):
            position = recorder.decode(block, position, segment, ROWS_PER_GROUP)
            if segment.rows >= ROWS_PER_GROUP:
                segment.clear()

    def decoder() -> None:
        decode = make_decoder(device_nodes()).decode
        for frame, at in decoded:
            decode(frame, at)

    def rows() -> None:
        frames = FrameDecoder(make_decoder(device_nodes()))
        segments.clear()
        segment = Segment()
        for block in blocks:
            position = 0
            while position < len(block):
                position = frames.decode(block, position, segment, ROWS_PER_GROUP)
                if segment.rows >= ROWS_PER_GROUP:
                    segments.append(segment)
                    segment = Segment()
        segments.append(segment)

    def write() -> None:
        writer = PartitionWriter(LocalFiles(), str(out), "unit.parquet", str(log))
        for segment in segments:
            writer.write(segment)
        writer.close()

    rows()
    print(f"  (the decoder decodes {len(decoded):,} of the log's frames; the others are "
          "other ECUs' frames it has seen, filled in per identifier)")
    return {"read": lambda: list(read_columns(log)), "decoder": decoder, "rows": rows,
            "write": write}


def _anchor_stages(log: Path, out: Path) -> dict[str, Callable[[], object]]:
    import can

    anchor: dict[str, Any] = {"__name__": "anchor"}
    exec(ANCHOR, anchor)  # the anchor's own text: it defines its functions
    known = anchor["known_messages"](device_nodes())
    messages = list(can.LogReader(log))
    groups: list[list[tuple[object, ...]]] = []

    def keep(rows: list[tuple[object, ...]]) -> None:
        groups.append(rows[:])
        rows.clear()

    def rows() -> None:
        groups.clear()
        anchor["decode"](messages, str(log), known, keep)

    def write() -> None:
        for group in groups:
            anchor["flush"](list(group), str(out))

    rows()
    return {"read": lambda: list(can.LogReader(log)), "rows": rows, "write": write}


def _tiny(log: Path, root: Path) -> Path:
    """The log's first 20 frames: a run on it is the start-up (interpreter, imports)."""
    tiny = root / "tiny.log"
    with log.open() as lines:
        tiny.write_text("".join(line for _, line in zip(range(20), lines, strict=False)))
    return tiny


def _start_ups(tiny: Path, root: Path) -> tuple[float, float]:
    """CPU seconds of ours and of the anchor on the 20-frame log."""
    ours = _run(_ours([tiny], root / "tiny-ours"))[1]
    anchor = _run([sys.executable, "-c", ANCHOR, str(tiny), str(root / "tiny-anchor"),
                   json.dumps(device_nodes())])[1]
    return ours, anchor


def stages(log: Path, frames: int, repeats: int, root: Path,
           start_ups: dict[str, list[float]]) -> None:
    """Where a frame's CPU goes, ours and the anchor's: each stage in this process (medians
    of interleaved repetitions), the start-up (``start_ups``: CPU seconds of each side's
    process on a 20-frame log) spread over the log's frames."""
    ours = _our_stages(log, root / "stages-ours")
    anchor = _anchor_stages(log, root / "stages-anchor")
    times: dict[str, list[float]] = {f"{side} start-up": values
                                     for side, values in start_ups.items()}
    for _ in range(repeats):
        for side, work in (("ours", ours), ("anchor", anchor)):
            for name, run in work.items():
                times.setdefault(f"{side} {name}", []).append(_cpu(run))
    per_frame = {name: statistics.median(values) / frames * 1e6 for name, values in times.items()}
    ours_split = {  # the decoder: on the frames the rows stage has it decode
        "reading": per_frame["ours read"], "decoder": per_frame["ours decoder"],
        "rows and texts": per_frame["ours rows"] - per_frame["ours decoder"],
        "Arrow + Parquet": per_frame["ours write"], "start-up": per_frame["ours start-up"]}
    anchor_split = {
        "reading": per_frame["anchor read"], "decoder": 0.0,
        "rows and texts": per_frame["anchor rows"], "Arrow + Parquet": per_frame["anchor write"],
        "start-up": per_frame["anchor start-up"]}
    total_ours, total_anchor = sum(ours_split.values()), sum(anchor_split.values())
    print(f"where a frame's CPU goes, us/frame ({frames:,} frames; start-up "
          f"{statistics.median(times['ours start-up']):.2f} s and "
          f"{statistics.median(times['anchor start-up']):.2f} s spread over them; {_load()})")
    print(f"  {'':18}{'blinkcan':>10}{'anchor':>10}   (the anchor's rows: cantools' decoding)")
    for name, value in ours_split.items():
        print(f"  {name:18}{value:10.2f}{anchor_split[name]:10.2f}   "
              f"{value / total_ours:4.0%} of ours")
    print(f"  {'sum':18}{total_ours:10.2f}{total_anchor:10.2f}   ratio "
          f"{total_anchor / total_ours:.2f}x")
    running_ours = total_ours - ours_split["start-up"]
    running_anchor = total_anchor - anchor_split["start-up"]
    print(f"  {'sum, no start-up':18}{running_ours:10.2f}{running_anchor:10.2f}   ratio "
          f"{running_anchor / running_ours:.2f}x")
    floor = ours_split["reading"] + ours_split["decoder"] + ours_split["start-up"]
    print(f"  3x the anchor is {total_anchor / 3:.2f} us/frame; reading, the decoder and the "
          f"start-up alone are {floor:.2f} (at most {total_anchor / floor:.2f}x with rows, "
          "Arrow and Parquet free)")


def end_to_end(log: Path, frames: int, repeats: int, root: Path
               ) -> tuple[list[float], dict[str, list[float]]]:
    """Both sides' processes on the log, interleaved, with and without their start-up;
    our frames per CPU second, and each side's start-up CPU seconds."""
    tiny = _tiny(log, root)
    devices = json.dumps(device_nodes())
    ours, anchor, ours_cpu, anchor_cpu = [], [], [], []
    start_ups: dict[str, list[float]] = {"ours": [], "anchor": []}
    for repeat in range(repeats):  # interleaved
        _, cpu = _run(_ours([log], root / f"ours-{repeat}"))
        ours.append(frames / cpu)
        ours_cpu.append(cpu)
        _, cpu = _run([sys.executable, "-c", ANCHOR, str(log), str(root / f"anchor-{repeat}"),
                       devices])
        anchor.append(frames / cpu)
        anchor_cpu.append(cpu)
        for side, cpu in zip(("ours", "anchor"), _start_ups(tiny, root), strict=True):
            start_ups[side].append(cpu)
    print(f"fleet decode to Parquet: a {frames:,}-frame realistic candump log, frames per "
          f"CPU second, end to end (target >= 3x); {_load()}")
    print(f"  blinkcan decode --parquet                {_spread(ours)}  {_micros(ours)}")
    print(f"  LogReader + cantools + pyarrow (anchor)  {_spread(anchor)}  "
          f"{_micros(anchor)}")
    ratios = [o / a for o, a in zip(ours, anchor, strict=True)]
    print(f"  ratio {statistics.median(ratios):.2f}x ({min(ratios):.2f}-{max(ratios):.2f})")
    # the same runs without the start-up (interpreter and imports: a 20-frame log's CPU)
    ours_running = [frames / (cpu - start) for cpu, start in
                    zip(ours_cpu, start_ups["ours"], strict=True)]
    anchor_running = [frames / (cpu - start) for cpu, start in
                      zip(anchor_cpu, start_ups["anchor"], strict=True)]
    running = [o / a for o, a in zip(ours_running, anchor_running, strict=True)]
    print(f"  start-up (a 20-frame log), CPU: ours "
          f"{statistics.median(start_ups['ours']):.2f} s, the anchor's "
          f"{statistics.median(start_ups['anchor']):.2f} s; without it:")
    print(f"  blinkcan decode --parquet                {_spread(ours_running)}  "
          f"{_micros(ours_running)}")
    print(f"  LogReader + cantools + pyarrow (anchor)  {_spread(anchor_running)}  "
          f"{_micros(anchor_running)}")
    print(f"  ratio {statistics.median(running):.2f}x ({min(running):.2f}-{max(running):.2f})")
    return ours, start_ups


def main(smoke: bool = False, scaling: bool = True, profile: bool = True,
         size: int | None = None) -> None:
    """The end-to-end figures on the 1 M-frame log of the speed issue (``size`` frames if
    given; 20,000 for a ``smoke`` run); then where the CPU goes (``profile``) and the -j 2
    scaling (``scaling``)."""
    frames = size if size is not None else 20_000 if smoke else 1_000_000
    repeats = 1 if smoke else 3
    with tempfile.TemporaryDirectory() as folder:
        root = Path(folder)
        log = root / "unit.log"
        traffic = realistic_traffic(frames)
        write_candump(log, traffic)
        del traffic
        ours, start_ups = end_to_end(log, frames, repeats, root)
        if profile:
            stages(log, frames, repeats, root, start_ups)
        if not scaling:
            return

        files = 4
        logs = [root / f"unit-{n}.log" for n in range(files)]
        for path in logs:  # copies: a file reached by several names is decoded once
            shutil.copyfile(log, path)
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
