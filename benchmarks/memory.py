"""Memory: ``blinkcan decode`` is flat in the log's size, and 127 twins fit in under 10 MB.

Decode: the realistic log of ``realistic_log.py`` at 1 M frames, and the same traffic written
ten times over (10 M frames, each copy's times after the one before), each decoded by
``blinkcan decode LOG --json`` and ``--parquet`` in a process of its own; the figure is that
process's peak resident set (``ru_maxrss``, interpreter and imports included, taken by a small
launcher process),
beside ``python -c "import can"``'s (the floor any python-can tool starts from). Flat means the
10 M figure is the 1 M figure, give or take a few MB of allocator noise.

Twins: 127 twins, each at its own node id, driven by an Emulator on a virtual bus for two
seconds of real time with 10 ms heartbeats, as ``blinkcan emulate`` runs them: the registry's
CANopen models in turn (mixed), then 127 of each model (the Keybox is the emulator's stress
figure; keypads hold more: their LED pictures and key state). The figure is the Python heap
they hold while they run (tracemalloc, less before they were built; the models' classes and
descriptions loaded beforehand), and the process's resident set grown meanwhile
(tracemalloc's own records included, so an upper bound). Target (DESIGN.md): under 10 MB.
"""

from __future__ import annotations

import gc
import os
import resource
import subprocess
import sys
import tempfile
import threading
import time
import tracemalloc
import uuid
from pathlib import Path

import can

from benchmarks.realistic_log import device_options, realistic_traffic
from blinkcan.devices.registry import models
from blinkcan.runtime import Emulator
from blinkcan.twin.registry import build_twin

LIMIT_MB = 10.0


#: runs its arguments as a child and prints the child's peak resident set in kB. A peak is kept
#: across exec, so a child forked from this (large) process would report this one's size: the
#: launcher is a small interpreter, smaller than any it starts.
_LAUNCHER = """
import os, subprocess, sys
child = subprocess.Popen(sys.argv[1:], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
_, status, usage = os.wait4(child.pid, 0)
print(os.waitstatus_to_exitcode(status), usage.ru_maxrss)
"""


def _peak_mb(arguments: list[str]) -> float:
    """Peak resident set of a child process, in MB."""
    launched = subprocess.run([sys.executable, "-c", _LAUNCHER, *arguments], check=True,
                              capture_output=True, text=True)
    code, peak = map(int, launched.stdout.split())
    if code not in (0, 1):  # 1: a decode that named unreadable lines
        raise RuntimeError(f"{arguments} exited {code}")
    return peak / 1024  # Linux: kilobytes


def _write_copies(path: Path, copies: int, frames: int) -> int:
    """``copies`` times the realistic traffic of ``frames`` frames, one after the other."""
    traffic = realistic_traffic(frames)
    span = traffic[-1][0] - traffic[0][0] + 0.001
    lines = [f"{item.can_id:08X}#" if item.extended else f"{item.can_id:03X}#"
             for _, item in traffic]
    lines = [f"{ident}{item.data.hex().upper()}\n" for ident, (_, item) in
             zip(lines, traffic, strict=True)]
    with path.open("w") as stream:
        for copy in range(copies):
            offset = 1_700_000_000 + copy * span
            stream.writelines(f"({moment + offset:.6f}) can0 {line}"
                              for (moment, _), line in zip(traffic, lines, strict=True))
    return copies * frames


def decode_figures(frames: int) -> dict[str, tuple[float, float]]:
    """(peak MB of 1x, of 10x the log) per way of decoding, and the ``import can`` floor."""
    blinkcan = [sys.executable, "-m", "blinkcan", "decode"]
    figures: dict[str, tuple[float, float]] = {}
    with tempfile.TemporaryDirectory() as folder:
        small, large = Path(folder, "one.log"), Path(folder, "ten.log")
        _write_copies(small, 1, frames)
        _write_copies(large, 10, frames)
        floor = _peak_mb([sys.executable, "-c", "import can"])
        figures["import can (floor)"] = (floor, floor)
        for name, extra in (("decode --json", ["--json"]), ("decode --parquet", None)):
            peaks = []
            for log in (small, large):
                options = extra if extra is not None else \
                    ["--parquet", str(Path(folder, f"lake-{log.stem}")), "--force"]
                peaks.append(_peak_mb([*blinkcan, str(log), *options, *device_options()]))
            figures[name] = (peaks[0], peaks[1])
    return figures


def twins_figure(names: list[str], count: int = 127, seconds: float = 2.0) -> tuple[float, float]:
    """(Python heap MB the twins hold, resident set MB grown) for ``count`` twins of the models
    ``names`` in turn, run by an Emulator on a virtual bus for ``seconds``."""
    channel = f"blinkcan-memory-{uuid.uuid4().hex}"
    for name in names:  # the models' classes and descriptions loaded: not the twins' own
        build_twin(name, node_id=1)
    gc.collect()
    rss_before = _rss_mb()
    tracemalloc.start()
    heap_before = tracemalloc.get_traced_memory()[0]
    twins = [build_twin(names[n % len(names)], node_id=n + 1,
                        settings={"producer_heartbeat_time": 10})  # 10 ms: a busy bus
             for n in range(count)]
    with can.Bus(interface="virtual", channel=channel) as bus, \
            can.Bus(interface="virtual", channel=channel) as reader:
        stop = threading.Event()
        drain = threading.Thread(target=lambda: _drain(reader, stop), daemon=True)
        drain.start()
        emulator = Emulator(bus, twins).start()
        time.sleep(seconds)
        gc.collect()
        heap = tracemalloc.get_traced_memory()[0] - heap_before  # while they run
        rss = _rss_mb() - rss_before
        emulator.stop()
        stop.set()
        drain.join()
    tracemalloc.stop()
    return heap / 1e6, rss


def _drain(bus: object, stop: threading.Event) -> None:
    while not stop.is_set():
        bus.recv(0.05)  # type: ignore[attr-defined]


def _rss_mb() -> float:
    with open("/proc/self/statm") as statm:
        return int(statm.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 1e6


def main(smoke: bool = False) -> None:
    frames = 10_000 if smoke else 1_000_000
    load = os.getloadavg()[0]
    print(f"memory: peak resident set of a decode of a realistic {frames:,}-frame candump log "
          f"and of ten copies of it ({10 * frames:,} frames), load average {load:.1f}")
    for name, (one, ten) in decode_figures(frames).items():
        print(f"  {name:<20} {one:6.1f} MB   10x the log {ten:6.1f} MB   "
              f"grown {ten - one:+.1f} MB")
    every_model = [found.name for found in models() if found.default_node_id]
    print("  127 twins run by an Emulator (10 ms heartbeats): the Python heap they hold, "
          "per twin, and the resident set grown")
    heaps = []
    for label, names in (("every model mixed", every_model),
                         *((f"127 {name}", [name]) for name in every_model)):
        heap, rss = twins_figure(names, 127, 0.5 if smoke else 2.0)
        heaps.append(heap)
        print(f"  {label:<20} heap {heap:5.1f} MB ({heap * 1000 / 127:5.1f} kB a twin), "
              f"resident set grown {rss:5.1f} MB")
    verdict = "met" if max(heaps) < LIMIT_MB else "NOT met"
    print(f"  the most of any: {max(heaps):.1f} MB (target < {LIMIT_MB:.0f} MB: {verdict})")
    print(f"  peak of this process {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f}"
          " MB")


if __name__ == "__main__":
    main(smoke="--smoke" in sys.argv)
