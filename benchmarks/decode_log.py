"""Decoding a realistic candump log end to end, against what a user would pick instead.

The log (benchmarks/realistic_log.py): the devices' own traffic made by the twins (a CANopen
twin of every registered model, a keypad in J1939 mode, SDO, heartbeats), one third other ECUs'
11-bit frames and one third J1939 engine and vehicle frames that no DBC of ours knows.

- JSON: ``blinkcan decode --json`` beside python-can's LogReader + cantools ``decode_message``
  with our DBC files (every model at its node, and the J1939 keypad's) + orjson, writing one
  line per frame (the signals where the DBC knows the frame, else the raw id and data; unknown
  ids skipped by a set lookup). Target (DESIGN.md): >= 1.5x.
- Text: ``blinkcan decode`` beside ``cantools decode --single-line`` with the same DBC file
  (stdin). Target >= 2x.
- Start-up: CPU of ``blinkcan --help`` and ``blinkcan decode`` of a 10-frame log beside
  ``cantools decode`` of the same 10 frames (floor: ``python -c "import can"``). Target: no more.
- An undecodable frame (a J1939 engine frame): our ``json_line`` and ``decode`` per frame, beside
  a loop that only skips it by a set lookup. Target <= 1 us.

Each is run as its own process, interpreter start included, output to /dev/null; ours and the
anchor alternate, and the figures are CPU seconds of that process (the machine is shared):
median (range) over the repetitions.
"""

from __future__ import annotations

import os
import sys
import tempfile
import time
from pathlib import Path

import cantools

from benchmarks.measure import child_cpu, interleaved, ratio_text, spread
from benchmarks.realistic_log import (
    OtherEcus,
    device_nodes,
    device_options,
    realistic_traffic,
    write_candump,
)
from blinkcan.decode import Decoder
from blinkcan.devices.registry import describe_device
from blinkcan.formats import dbc_j1939
from blinkcan.formats.dbc import dbc_text

ANCHOR = r"""
import sys
import can, cantools, orjson
db = cantools.database.load_file(sys.argv[1])
decode = db.decode_message
known = {m.frame_id for m in db.messages}
write = sys.stdout.write
dumps = orjson.dumps
with can.LogReader(sys.argv[2]) as reader:
    for msg in reader:
        record = {"time": msg.timestamp, "id": msg.arbitration_id, "data": msg.data.hex()}
        if msg.arbitration_id in known:
            try:
                record["signals"] = decode(msg.arbitration_id, msg.data, decode_choices=False)
            except Exception:  # a frame the DBC cannot decode (an unknown multiplexer value)
                pass
        write(dumps(record).decode() + "\n")
"""


def write_dbc(path: Path) -> Path:
    """One DBC file: every model at its node in the log, and the J1939 keypad's messages."""
    database = cantools.database.Database()
    for node, name in device_nodes().items():
        database.add_dbc_string(dbc_text(describe_device(name), node))
    database.add_dbc_string(dbc_j1939.dbc_text())
    path.write_text(database.as_dbc_string())
    return path


def _undecodable(count: int) -> tuple[float, float, float]:
    """Microseconds per J1939 engine frame: our json_line, our decode, a set-lookup skip."""
    import random

    others = OtherEcus(random.Random(7), set(device_nodes()))
    frames = [others.extended_frame() for _ in range(count)]
    decoder = Decoder(dict(device_nodes().items()))
    json_line, decode = decoder.json_line, decoder.decode
    known = {0x18EFFF21, 0x18EF2100}
    best = [float("inf")] * 3

    def ours_json() -> None:
        for frame in frames:
            json_line(frame, 1.5)

    def ours_decode() -> None:
        for frame in frames:
            decode(frame, 1.5)

    def skip() -> None:
        for frame in frames:
            if frame.can_id in known:
                pass

    for _ in range(5):
        for i, run in enumerate((ours_json, ours_decode, skip)):
            start = time.process_time()  # CPU: steadier than the wall on a shared machine
            run()
            best[i] = min(best[i], (time.process_time() - start) / count * 1e6)
    return best[0], best[1], best[2]


def _load() -> str:
    """The machine's 1-minute load average: CPU figures of a shared machine say it beside."""
    return f"{os.getloadavg()[0]:.1f}"


def main(smoke: bool = False) -> None:
    frames, repeats = (20_000, 1) if smoke else (1_000_000, 3)
    python = sys.executable
    with tempfile.TemporaryDirectory() as folder:
        log, ten, dbc = Path(folder) / "bus.log", Path(folder) / "ten.log", Path(folder) / "all.dbc"
        traffic = realistic_traffic(frames)
        count = write_candump(log, traffic)
        write_candump(ten, traffic[:10])
        write_dbc(dbc)
        ours = [python, "-m", "blinkcan", "decode", *device_options()]
        print(f"decode a realistic {count:,}-frame candump log (a third the devices', a third "
              "other 11-bit, a third J1939 engine frames): frames per CPU-second, median (range) "
              f"of {repeats}; load average {_load()}")
        json_runs = interleaved({
            "ours": lambda: child_cpu([*ours, "--json", str(log)]),
            "anchor": lambda: child_cpu([python, "-c", ANCHOR, str(dbc), str(log)]),
        }, repeats)
        print(f"  JSON  blinkcan decode --json           "
              f"{spread([count / t for t in json_runs['ours']])}")
        print(f"        LogReader + cantools + orjson      "
              f"{spread([count / t for t in json_runs['anchor']])}")
        print(f"        ratio {ratio_text(json_runs['ours'], json_runs['anchor'])}"
              "  (target >= 1.5x)")
        text_runs = interleaved({
            "ours": lambda: child_cpu([*ours, str(log)]),
            "anchor": lambda: child_cpu([python, "-m", "cantools", "decode", "--single-line",
                                         str(dbc)], stdin=log),
        }, repeats)
        print(f"  text  blinkcan decode                  "
              f"{spread([count / t for t in text_runs['ours']])}")
        print(f"        cantools decode --single-line      "
              f"{spread([count / t for t in text_runs['anchor']])}")
        print(f"        ratio {ratio_text(text_runs['ours'], text_runs['anchor'])}"
              "  (target >= 2x)")
        start_runs = interleaved({
            "help": lambda: child_cpu([python, "-m", "blinkcan", "--help"]),
            "decode": lambda: child_cpu([*ours, str(ten)]),
            "anchor": lambda: child_cpu([python, "-m", "cantools", "decode", str(dbc)],
                                        stdin=ten),
            "floor": lambda: child_cpu([python, "-c", "import can"]),
        }, 2 if smoke else 7)
        print("  start-up, CPU ms: "
              f"blinkcan --help {spread(start_runs['help'], 1000)}, "
              f"blinkcan decode (10 frames) {spread(start_runs['decode'], 1000)}; "
              f"cantools decode (anchor) {spread(start_runs['anchor'], 1000)}; "
              f"import can (floor) {spread(start_runs['floor'], 1000)}")
        print(f"        ratio --help {ratio_text(start_runs['help'], start_runs['anchor'])}, "
              f"decode {ratio_text(start_runs['decode'], start_runs['anchor'])}"
              "  (target >= 1.00x: no more CPU than the anchor)")
    print(f"  load average after the runs {_load()}")
    as_json, as_event, skip = _undecodable(20_000 if smoke else 200_000)
    print(f"  an undecodable J1939 engine frame: json_line {as_json:.2f} us, decode "
          f"{as_event:.2f} us; a loop that skips it by id {skip:.2f} us (target <= 1 us)")
