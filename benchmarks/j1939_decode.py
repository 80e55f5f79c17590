"""J1939 keypad traffic decoded, frames per second: blinkcan's decoder (texts and fields, with
the direction told by the addresses) against cantools ``decode_message`` with blinkcan's J1939
DBC (formats/dbc_j1939.py), the same frames: key messages, heartbeats, LED commands, settings.

No target in DESIGN.md: this measures what reading the command tables costs against the
field's standard DBC decoder.
"""

from __future__ import annotations

import random
import time
from typing import Any

import cantools

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


def main(smoke: bool = False) -> None:
    count, repeats = (2_000, 2) if smoke else (100_000, 5)
    frames = _frames(count)
    database: Any = cantools.database.load_string(dbc_text(), "dbc")
    decoder = Decoder()
    decode, anchor_decode = decoder.decode, database.decode_message

    def ours() -> None:
        for frame in frames:
            decode(frame, 0.0)

    def anchor() -> None:
        for frame in frames:
            anchor_decode(frame.can_id, frame.data)

    best = [0.0, 0.0]
    for _ in range(repeats):
        for i, run in enumerate((ours, anchor)):
            start = time.perf_counter()
            run()
            best[i] = max(best[i], count / (time.perf_counter() - start))
    print("J1939 keypad frames decoded (frames/s)")
    print(f"  blinkcan Decoder {best[0]:>10,.0f}   cantools + J1939 DBC {best[1]:>10,.0f}"
          f"   ratio {best[0] / best[1]:.2f}x")


if __name__ == "__main__":
    main()
