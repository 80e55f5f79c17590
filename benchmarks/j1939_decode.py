"""J1939 keypad traffic decoded, frames per second: blinkcan's decoder (texts and fields, with
the direction told by the addresses) against cantools ``decode_message`` with blinkcan's J1939
DBC (formats/dbc_j1939.py), the same frames: key messages, heartbeats, LED commands, settings.

Also a bus mix: the keypad's frames interleaved with J1939 engine and vehicle frames
(benchmarks/realistic_log.py), which the anchor skips by a set lookup of the DBC's ids.
Target (DESIGN.md): >= 1.5x on both; medians (ranges) of interleaved passes.
"""

from __future__ import annotations

import contextlib
import random
import time
from typing import Any

import cantools

from benchmarks.measure import interleaved, ratio_text, spread
from benchmarks.realistic_log import OtherEcus
from blinkcan.decode import Decoder
from blinkcan.formats.dbc_j1939 import dbc_text
from blinkcan.protocol import Frame


def _frames(count: int) -> list[Frame]:
    """Varied frames of one keypad at 21h and its controller at 00h (seeded)."""
    chooser = random.Random(13)
    frames = []
    for _ in range(count):
        kind = chooser.randrange(4)
        key = chooser.randint(1, 12)
        if kind == 0:
            data = bytes((0x04, 0x1B, 0x01, key, chooser.randint(0, 1), 0x21, 0xFF, 0xFF))
            frames.append(Frame(0x18EFFF21, data, True))
        elif kind == 1:
            keys = chooser.getrandbits(12)
            data = bytes((0x04, 0x1B, 0xF9, chooser.randrange(256), keys & 0xFF, keys >> 8,
                          0xFF, 0x21))
            frames.append(Frame(0x18EFFF21, data, True))
        elif kind == 2:
            data = bytes((0x04, 0x1B, 0x01, key, chooser.randint(0, 9), chooser.randint(0, 3),
                          chooser.randint(0, 9), 0xFF))
            frames.append(Frame(0x18EF2100, data, True))
        else:
            data = bytes((0x04, 0x1B, 0x02, chooser.randint(0, 0x3F), 0xFF, 0xFF, 0xFF, 0xFF))
            frames.append(Frame(0x18EF2100, data, True))
    return frames


def _mix(keypad: list[Frame], count: int) -> list[Frame]:
    """The keypad's frames interleaved with J1939 engine and vehicle frames, half each."""
    others = OtherEcus(random.Random(5), set())
    mixed: list[Frame] = []
    for frame in keypad[: count // 2]:
        mixed += (frame, others.extended_frame())
    return mixed


def _compare(frames: list[Frame], repeats: int) -> tuple[list[float], list[float]]:
    """Seconds per pass over ``frames``, ours and the anchor's, interleaved."""
    database: Any = cantools.database.load_string(dbc_text(), "dbc")
    known = {m.frame_id for m in database.messages}
    anchor_decode = database.decode_message

    def ours() -> float:
        decode = Decoder().decode  # a fresh decoder each pass: no state carried over
        start = time.process_time()
        for frame in frames:
            decode(frame, 0.0)
        return time.process_time() - start

    def anchor() -> float:
        start = time.process_time()
        for frame in frames:
            if frame.can_id in known:
                with contextlib.suppress(Exception):  # a command the DBC has no layout for
                    anchor_decode(frame.can_id, frame.data)
        return time.process_time() - start

    runs = interleaved({"ours": ours, "anchor": anchor}, repeats)
    return runs["ours"], runs["anchor"]


def main(smoke: bool = False) -> None:
    count, repeats = (4_000, 3) if smoke else (100_000, 7)
    keypad = _frames(count)
    print("J1939 decoded, frames/s, median (range): blinkcan Decoder beside cantools with our "
          "J1939 DBC (unknown ids skipped by a set lookup)")
    for label, frames in (("keypad frames", keypad), ("bus mix with engine frames",
                                                      _mix(keypad, count))):
        ours, anchor = _compare(frames, repeats)
        print(f"  {label:<27} blinkcan {spread([len(frames) / t for t in ours])}   "
              f"cantools {spread([len(frames) / t for t in anchor])}   "
              f"ratio {ratio_text(ours, anchor)} (target >= 1.5x)")


if __name__ == "__main__":
    main()
