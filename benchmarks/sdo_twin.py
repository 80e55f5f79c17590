"""Pure twin: SDO requests handled per second on a mixed upload/download stream.

Anchor: python-canopen's ``SdoServer.on_request`` (a ``LocalNode`` with the same object
dictionary, built by ``formats.canopen_od``) fed the same request bytes, sending stubbed out.
Target (DESIGN.md): >= 1.5x the anchor.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import canopen

from blinkcan.formats.canopen_od import object_dictionary
from blinkcan.protocol import Frame
from blinkcan.twin import KeypadTwin

#: The stream: reads and writes of settings, LEDs and identity objects, expedited.
STREAM_HEX = [
    "4000100000000000",  # read 1000h
    "2B00180564000000",  # write 1800h/05 = 100 ms
    "4017100000000000",  # read 1017h
    "2B01200142000000",  # write 2001h/01
    "4001200100000000",  # read 2001h/01
    "2F03200120000000",  # write 2003h/01
    "4003200100000000",  # read 2003h/01
    "4018100100000000",  # read 1018h/01
]


def _best_rate(run: Callable[[], None], count: int, repeats: int) -> float:
    best = 0.0
    for _ in range(repeats):
        start = time.perf_counter()
        run()
        elapsed = time.perf_counter() - start
        best = max(best, count / elapsed)
    return best


def measure(rounds: int, repeats: int) -> tuple[float, float]:
    """(ours, anchor) requests per second."""
    stream = [bytes.fromhex(h) for h in STREAM_HEX] * rounds
    count = len(stream)

    twin = KeypadTwin()
    twin.power_on(0.0)
    frames = [Frame(0x615, data) for data in stream]
    receive = twin.receive

    def ours() -> None:
        for frame in frames:
            receive(frame, 1.0)

    node = canopen.LocalNode(0x15, object_dictionary(twin.description, 0x15))
    server: Any = node.sdo
    server.send_response = lambda response: None  # sending stubbed out
    on_request = server.on_request

    def anchor() -> None:
        for data in stream:
            on_request(0x615, data, 0.0)

    ours()  # warm up both
    anchor()
    replies: list[bytes] = []
    server.send_response = replies.append
    for data in stream[: len(STREAM_HEX)]:
        on_request(0x615, data, 0.0)
    aborted = [r.hex() for r in replies if r[0] == 0x80]
    if aborted or len(replies) != len(STREAM_HEX):  # the anchor must do the real work
        raise RuntimeError(f"python-canopen did not answer the stream cleanly: {aborted}")
    server.send_response = lambda response: None
    return _best_rate(ours, count, repeats), _best_rate(anchor, count, repeats)


def main(smoke: bool = False) -> None:
    rounds, repeats = (500, 2) if smoke else (25_000, 5)
    ours, anchor = measure(rounds, repeats)
    print("pure twin, mixed expedited SDO stream (requests/s)")
    print(f"  blinkcan KeypadTwin.receive       {ours:>12,.0f}")
    print(f"  python-canopen SdoServer (anchor) {anchor:>12,.0f}")
    print(f"  ratio {ours / anchor:.2f}x (target >= 1.5x)")
