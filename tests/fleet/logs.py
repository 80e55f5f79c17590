"""Fleet test logs: the twins' traffic on a Rig (keys, fuses, a lost heartbeat) plus other
ECUs' 11-bit and 29-bit frames, written in the formats blinkcan reads."""

from __future__ import annotations

import gzip
from collections.abc import Iterator
from pathlib import Path

import can

from blinkcan.protocol.frame import Frame
from blinkcan.testing import Rig
from blinkcan.twin import KeyboxTwin, KeypadTwin

#: a minute before midnight UTC, 31 May 2026: the log crosses into 1 June
EPOCH = 1_780_271_940.0
Traffic = list[tuple[float, Frame]]
FOREIGN = (Frame(0x181, bytes(range(8))), Frame(0x0CF00400, bytes(8), extended=True),
           Frame(0x18FEF100, bytes((0xFF,) * 8), extended=True))


def rig_traffic(taps: int = 3, fuse_pin: int = 4) -> Traffic:
    """Both twins started with 100 ms heartbeats, the Keybox's output ``fuse_pin`` on;
    ``taps`` taps of key 1 (then key 2), a fuse blown and replaced, the keypad's heartbeat
    lost for a second; 120 s in all."""
    rig = Rig()
    keypad, keybox = rig.add(KeypadTwin()), rig.add(KeyboxTwin())
    for text in ("000#0100", f"6{keypad.node_id:02X}#2B17100064000000",
                 f"6{keybox.node_id:02X}#2B17100064000000"):
        ident, data = text.split("#")
        rig.bus.send(can.Message(arbitration_id=int(ident, 16), data=bytes.fromhex(data),
                                 is_extended_id=False))
        rig.settle()
    outputs = keybox.description.pdo("outputs")
    rig.bus.send(can.Message(arbitration_id=outputs.cob_id(keybox.node_id),
                             data=outputs.encode({"off": 0, "high": 1 << (fuse_pin - 1)}),
                             is_extended_id=False))
    rig.settle()
    for tap in range(taps):
        rig.tap(keypad, 1 + tap % 2)
        rig.advance(1.0)
    rig.blow_fuse(keybox, fuse_pin)
    rig.advance(2.0)
    restore = rig.stop_heartbeat(keypad.node_id)
    rig.advance(1.0)
    restore()
    rig.replace_fuse(keybox, fuse_pin)
    rig.advance(120.0 - rig.now)
    frames = [(timed.time, timed.frame) for timed in rig.frames]
    rig.close()
    return frames


def fleet_traffic(taps: int = 3) -> Traffic:
    """The twins' traffic with a foreign frame every 0.25 s, times from EPOCH."""
    traffic = rig_traffic(taps)
    foreign = [(0.25 * n + 0.0001, FOREIGN[n % len(FOREIGN)]) for n in range(480)]
    return sorted(((t + EPOCH, f) for t, f in traffic + foreign), key=lambda item: item[0])


def candump_lines(traffic: Traffic, channel: str = "can0") -> Iterator[str]:
    for time, frame in traffic:
        ident = f"{frame.can_id:08X}" if frame.extended else f"{frame.can_id:03X}"
        yield f"({time:.6f}) {channel} {ident}#{frame.data.hex().upper()}\n"


def write_log(path: Path, traffic: Traffic) -> Path:
    """``traffic`` as a log in the format ``path`` names: .log, .log.gz, .log.zst, or any
    format python-can writes (through blinkcan's FrameWriter, .pcap included)."""
    name = path.name.lower()
    if name.endswith(".log"):
        path.write_text("".join(candump_lines(traffic)))
    elif name.endswith(".log.gz"):
        with gzip.open(path, "wt") as stream:
            stream.writelines(candump_lines(traffic))
    elif name.endswith(".log.zst"):
        import zstandard

        text = "".join(candump_lines(traffic)).encode()
        path.write_bytes(zstandard.ZstdCompressor().compress(text))
    elif name.endswith(".gz"):  # another format, gzipped as a logger would
        plain = write_log(path.with_name(path.name[:-3]), traffic)
        path.write_bytes(gzip.compress(plain.read_bytes()))
        plain.unlink()
    else:
        from blinkcan.formats.logs import FrameWriter

        with FrameWriter(path) as writer:
            for time, frame in traffic:
                writer.write(time, frame)
    return path
