"""A short deterministic session of both twins, as (time, frame) pairs, for golden tests."""

from __future__ import annotations

from blinkcan.protocol import Frame
from blinkcan.twin import KeyboxTwin, KeypadTwin
from tests.conftest import frame


def session() -> list[tuple[float, Frame]]:
    keypad, keybox = KeypadTwin(), KeyboxTwin()
    twins = (keypad, keybox)
    log: list[tuple[float, Frame]] = []
    for twin in twins:
        log += [(0.0, f) for f in twin.power_on(0.0)]

    def host(now: float, text: str) -> None:
        sent = frame(text)
        log.append((now, sent))
        for twin in twins:
            log.extend((now, reply) for reply in twin.receive(sent, now))

    host(0.1, "615 40 00 10 00 00 00 00 00")
    host(0.2, "60C 40 0B 10 00 00 00 00 00")
    host(0.21, "60C 60 00 00 00 00 00 00 00")
    host(0.3, "000 01 00")
    log.extend((0.4, f) for f in keypad.press(4, 0.4))
    log.extend((0.5, f) for f in keypad.release(4, 0.5))
    host(0.6, "215 42 00 01 00 00 00 00 00")
    host(0.7, "20C 00 00 08 00 00 00 00 00")
    log.extend((0.8, f) for f in keybox.blow_fuse(4, 0.8))
    host(0.9, "60C 2F 01 20 04 02 00 00 00")
    host(1.0, "615 2B 17 10 00 05 00 00 00")
    return log
