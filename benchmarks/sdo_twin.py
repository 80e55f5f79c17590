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
from blinkcan.twin import KeyboxTwin, KeypadTwin
from blinkcan.twin.base import CanopenTwin

#: The streams: reads and writes of settings, outputs and identity objects, expedited.
KEYBOX_STREAM_HEX = [
    "4000100000000000",  # read 1000h
    "2B12200064000000",  # write 2012h = 100 (periodic faults, 10 ms units)
    "4012200000000000",  # read 2012h
    "2B08200200000000",  # write 2008h/02 (HIGH mask, no pin)
    "4008200200000000",  # read 2008h/02
    "2F13200001000000",  # write 2013h = 1
    "4001200400000000",  # read 2001h/04
    "4018100100000000",  # read 1018h/01
]
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


def _best_rates(ours: Callable[[], None], anchor: Callable[[], None], count: int,
                repeats: int) -> tuple[float, float]:
    """Best rate of each, their repeats interleaved so both see the same machine load."""
    best = [0.0, 0.0]
    for _ in range(repeats):
        for i, run in enumerate((ours, anchor)):
            start = time.perf_counter()
            run()
            best[i] = max(best[i], count / (time.perf_counter() - start))
    return best[0], best[1]


def measure(twin: CanopenTwin, stream_hex: list[str], rounds: int, repeats: int
            ) -> tuple[float, float]:
    """(ours, anchor) requests per second."""
    stream = [bytes.fromhex(h) for h in stream_hex] * rounds
    count = len(stream)
    node_id = twin.node_id
    twin.power_on(0.0)
    frames = [Frame(0x600 + node_id, data) for data in stream]
    receive = twin.receive

    def ours() -> None:
        for frame in frames:
            receive(frame, 1.0)

    node = canopen.LocalNode(node_id, object_dictionary(twin.description, node_id))
    server: Any = node.sdo
    server.send_response = lambda response: None  # sending stubbed out
    on_request = server.on_request

    def anchor() -> None:
        for data in stream:
            on_request(0x600 + node_id, data, 0.0)

    ours()  # warm up both
    anchor()
    replies: list[bytes] = []
    server.send_response = replies.append
    for data in stream[: len(stream_hex)]:
        on_request(0x600 + node_id, data, 0.0)
    aborted = [r.hex() for r in replies if r[0] == 0x80]
    if aborted or len(replies) != len(stream_hex):  # the anchor must do the real work
        raise RuntimeError(f"python-canopen did not answer the stream cleanly: {aborted}")
    server.send_response = lambda response: None
    return _best_rates(ours, anchor, count, repeats)


def main(smoke: bool = False) -> None:
    rounds, repeats = (500, 2) if smoke else (25_000, 5)
    print("pure twin, mixed expedited SDO stream (requests/s; target >= 1.5x the anchor)")
    for name, twin, stream_hex in (("KeypadTwin", KeypadTwin(), STREAM_HEX),
                                   ("KeyboxTwin", KeyboxTwin(), KEYBOX_STREAM_HEX)):
        ours, anchor = measure(twin, stream_hex, rounds, repeats)
        print(f"  {name}.receive {ours:>10,.0f}   python-canopen SdoServer {anchor:>10,.0f}"
              f"   ratio {ours / anchor:.2f}x")
