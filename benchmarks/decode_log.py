"""Decoding a large candump log end to end: ``blinkcan decode --json`` beside python-can's
LogReader + cantools ``decode_message`` (with our DBC) + ``json.dumps`` on the same file.

Both run as their own process writing to /dev/null, interpreter start included. The anchor
writes one JSON object per frame too (signals where the DBC knows the frame, else the raw id
and data). Target (DESIGN.md): >= 1.5x the anchor's frames/s on VARIED traffic: random
payloads on every documented PDO COB-ID of a keypad and a Keybox (random key, LED, brightness,
output and fault masks), heartbeats, and SDO reads of their objects answered by the twins, so
that no cache of ours can carry the result. The repetitive log (a 6-frame cycle with key
presses) is the second figure.
"""

from __future__ import annotations

import os
import random
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from tests.conftest import frame

from blinkcan.devices.pdo import PdoLayout
from blinkcan.protocol import Frame
from blinkcan.protocol.cob import HEARTBEAT, NMT, SDO_RX
from blinkcan.twin import KeyboxTwin, KeypadTwin

ANCHOR = r"""
import json, sys
import can, cantools
from blinkcan.devices.registry import describe_device
from blinkcan.formats.dbc import dbc_text
db = cantools.database.Database()
for name in ("keypad", "keybox"):
    db.add_dbc_string(dbc_text(describe_device(name)))
known = {m.frame_id for m in db.messages}
out = sys.stdout
with can.LogReader(sys.argv[1]) as reader:
    for msg in reader:
        record = {"time": msg.timestamp, "id": msg.arbitration_id, "data": msg.data.hex()}
        if msg.arbitration_id in known:
            record["signals"] = db.decode_message(msg.arbitration_id, msg.data,
                                                  decode_choices=False)
        out.write(json.dumps(record) + "\n")
"""


def _traffic(rounds: int) -> list[tuple[float, Frame]]:
    """Mixed traffic of both twins: heartbeats, key PDOs, LED PDOs, outputs, faults, SDO."""
    keypad, keybox = KeypadTwin(), KeyboxTwin()
    log: list[tuple[float, Frame]] = []
    for twin in (keypad, keybox):
        log += [(0.0, f) for f in twin.power_on(0.0)]
    requests = ["000 01 00", "615 2B 17 10 00 0A 00 00 00", "60C 2B 17 10 00 0A 00 00 00"]
    for step, text in enumerate(requests):
        sent, at = frame(text), step * 0.001
        log.append((at, sent))
        for twin in (keypad, keybox):
            log += [(at, f) for f in twin.receive(sent, at)]
    cycle = [frame(t) for t in ("215 42 00 01 00 00 00 00 00", "315 00 00 CC 00 03 00 00 00",
                                "20C 00 00 09 00 00 00 00 00", "20C 09 00 00 00 00 00 00 00",
                                "615 40 00 20 01 00 00 00 00", "60C 40 08 20 02 00 00 00 00")]
    now = 0.01
    for i in range(rounds):
        now += 0.01
        for twin in (keypad, keybox):
            log += [(now, f) for f in twin.advance(now)]
        key = 1 + i % 12
        log += [(now, f) for f in keypad.press(key, now)]
        log += [(now, f) for f in keypad.release(key, now)]
        sent = cycle[i % len(cycle)]
        log.append((now, sent))
        for twin in (keypad, keybox):
            log += [(now, f) for f in twin.receive(sent, now)]
    return log


def _random_pdo(layout: PdoLayout, node: int, chance: random.Random) -> Frame:
    values = {s.name: chance.getrandbits(s.length) for s in layout.signals}
    return Frame(layout.cob_id(node), layout.encode(values))


def varied_traffic(frames: int, seed: int = 14) -> list[tuple[float, Frame]]:
    """Heartbeats (10 %), SDO reads answered by the twins (10 %: request and reply), and
    random payloads on every PDO COB-ID the descriptions document (the rest)."""
    chance = random.Random(seed)
    twins = (KeypadTwin(), KeyboxTwin())
    log: list[tuple[float, Frame]] = []
    for twin in twins:
        log += [(0.0, f) for f in twin.power_on(0.0)]
    start = Frame(NMT, bytes((0x01, 0x00)))
    log.append((0.0, start))
    for twin in twins:
        log += [(0.0, f) for f in twin.receive(start, 0.0)]
    pdos = [(layout, twin.node_id) for twin in twins for layout in twin.description.pdos]
    readable = [(twin, entry) for twin in twins for entry in twin.description.table
                if entry.access.readable and not entry.data_type.is_string]
    now = 0.0
    while len(log) < frames:
        now += 0.0005
        roll = chance.random()
        if roll < 0.10:
            twin = chance.choice(twins)
            log.append((now, Frame(HEARTBEAT + twin.node_id, b"\x05")))
        elif roll < 0.15:
            twin, entry = chance.choice(readable)
            request = Frame(SDO_RX + twin.node_id, bytes((0x40,)) + entry.mux + bytes(4))
            log.append((now, request))
            log += [(now, reply) for reply in twin.receive(request, now)]
        else:
            layout, node = chance.choice(pdos)
            log.append((now, _random_pdo(layout, node, chance)))
    return log[:frames]


def write_candump(path: Path, frames: int, varied: bool = True) -> int:
    """A candump log of ``frames`` frames (written directly: it is only test data)."""
    traffic = varied_traffic(frames) if varied else _traffic(frames // 5 + 1)[:frames]
    with path.open("w") as stream:
        for timestamp, item in traffic:
            stream.write(f"({timestamp + 1_700_000_000:.6f}) can0 {item.can_id:03X}#"
                         f"{item.data.hex().upper()}\n")
    return len(traffic)


def _run(arguments: list[str]) -> float:
    start = time.perf_counter()
    with open(os.devnull, "w") as sink:
        subprocess.run(arguments, stdout=sink, check=True)
    return time.perf_counter() - start


def _measure(path: Path) -> tuple[float, float]:
    ours = _run([sys.executable, "-m", "blinkcan", "decode", "--json", str(path),
                 "--device", "0x15=keypad", "--device", "0x0C=keybox"])
    anchor = _run([sys.executable, "-c", ANCHOR, str(path)])
    return ours, anchor


def main(smoke: bool = False) -> None:
    frames = 50_000 if smoke else 1_000_000
    for varied, what in ((True, "VARIED traffic (the target)"),
                         (False, "a repetitive 6-frame cycle")):
        with tempfile.TemporaryDirectory() as folder:
            path = Path(folder) / "traffic.log"
            count = write_candump(path, frames, varied)
            ours, anchor = _measure(path)
        print(f"decode a {count:,}-frame candump log of {what} to JSON lines, end to end"
              + (" (target >= 1.5x)" if varied else ""))
        print(f"  blinkcan decode --json              {count / ours:>10,.0f} frames/s")
        print(f"  LogReader + cantools + json (anchor) {count / anchor:>10,.0f} frames/s")
        print(f"  ratio {anchor / ours:.2f}x")
