"""Pure twin: SDO requests handled per second on a mixed upload/download stream.

Anchor: python-canopen's ``SdoServer.on_request`` (a ``LocalNode`` with the same object
dictionary, built by ``formats.canopen_od``) fed the same request bytes, sending stubbed out.
Target (DESIGN.md): >= 1.5x the anchor. CPU seconds (time.process_time), repetitions of ours
and the anchor's interleaved, median and range: the machine is shared.
"""

from __future__ import annotations

import random
import time
from collections.abc import Callable
from typing import Any, TypeVar

import canopen

from benchmarks.measure import interleaved, ratio_text, spread
from blinkcan.formats.canopen_od import object_dictionary
from blinkcan.protocol import Frame
from blinkcan.twin import KeyboxTwin, KeypadTwin
from blinkcan.twin.base import CanopenTwin

T = TypeVar("T")

#: The streams: reads and writes of settings, outputs and identity objects, expedited. A read
#: repeats its bytes (a polling master's do); a write carries a new value each round, drawn
#: from the object's valid range (``WRITE_VALUES``), so no cache of request bytes can answer it.
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


#: The valid values of each write of the streams (devices/: the objects' ``valid`` ranges).
WRITE_VALUES: dict[str, range] = {
    "2B12200064000000": range(65280),  # fault_period
    "2B08200200000000": range(8192),  # output_high_mask
    "2F13200001000000": range(2),  # active_on_startup
    "2B00180564000000": range(10, 65280),  # tpdo1_event_timer
    "2B01200142000000": range(4096),  # led_on_red
    "2F03200120000000": range(64),  # indicator_brightness
}


def requests(stream_hex: list[str], rounds: int, new_values: bool, seed: int = 1) -> list[bytes]:
    """``rounds`` passes over the stream: reads as written; each write as written too, or
    (``new_values``) with a value drawn from its valid range (``WRITE_VALUES``), little-endian
    in the bytes its command names."""
    if not new_values:
        return [bytes.fromhex(h) for h in stream_hex] * rounds
    draw = random.Random(seed)
    templates = [bytes.fromhex(h) for h in stream_hex]
    ranges = [WRITE_VALUES.get(h) for h in stream_hex]
    out: list[bytes] = []
    for _ in range(rounds):
        for template, values in zip(templates, ranges, strict=True):
            if values is None:
                out.append(template)
                continue
            size = 4 - ((template[0] >> 2) & 3)  # CiA 301 §7.2.4.3.3: n unused bytes
            value = draw.choice(values).to_bytes(size, "little")
            out.append(template[:4] + value + template[4 + size:])
    return out


def _cpu_seconds(run: Callable[[list[T]], None], stream: list[bytes],
                 wrap: Callable[[bytes], T]) -> Callable[[], float]:
    """One repetition: CPU seconds of ``run`` over fresh copies of the request bytes (as a bus
    delivers them: new objects, no hash computed yet), the copying not counted."""

    def repetition() -> float:
        fresh = [wrap(bytes(bytearray(data))) for data in stream]
        start = time.process_time()
        run(fresh)
        return time.process_time() - start

    return repetition


def measure(twin: CanopenTwin, stream_hex: list[str], rounds: int, repeats: int,
            new_values: bool = True) -> tuple[list[float], list[float]]:
    """(ours, anchor) CPU seconds per repetition, interleaved."""
    stream = requests(stream_hex, rounds, new_values)
    node_id = twin.node_id
    twin.power_on(0.0)
    receive = twin.receive
    request_id = 0x600 + node_id

    def ours(requests: list[Frame]) -> None:
        for frame in requests:
            receive(frame, 1.0)

    node = canopen.LocalNode(node_id, object_dictionary(twin.description, node_id))
    server: Any = node.sdo
    server.send_response = lambda response: None  # sending stubbed out
    on_request = server.on_request

    def anchor(requests: list[bytes]) -> None:
        for data in requests:
            on_request(request_id, data, 0.0)

    def frame(data: bytes) -> Frame:
        return Frame(request_id, data)

    ours([frame(data) for data in stream])  # warm up both
    anchor(stream)
    replies: list[bytes] = []
    server.send_response = replies.append
    checked = stream[: 50 * len(stream_hex)]
    for data in checked:
        on_request(request_id, data, 0.0)
    ours_replies = [reply.data for data in checked for reply in receive(frame(data), 1.0)]
    for who, answers in (("python-canopen", replies), ("the twin", ours_replies)):
        aborted = [r.hex() for r in answers if r[0] == 0x80]
        if aborted or len(answers) != len(checked):  # both must do the real work
            raise RuntimeError(f"{who} did not answer the stream cleanly: {aborted[:3]}")
    server.send_response = lambda response: None
    times = interleaved({"ours": _cpu_seconds(ours, stream, frame),
                         "anchor": _cpu_seconds(anchor, stream, bytes)}, repeats)
    return times["ours"], times["anchor"]


def main(smoke: bool = False) -> None:
    rounds, repeats = (500, 3) if smoke else (20_000, 9)
    print("pure twin, mixed expedited SDO stream: requests/s, CPU time, median (range) of "
          f"{repeats} interleaved repetitions; target >= 1.5x the anchor on the repeated stream")
    for new_values, stream_name in ((False, "the same bytes every round (a polling master)"),
                                    (True, "writes with new values (the twin switches outputs "
                                           "and LEDs; SdoServer stores a number)")):
        print(f" {stream_name}:")
        for name, twin, stream_hex in (("KeypadTwin", KeypadTwin(), STREAM_HEX),
                                       ("KeyboxTwin", KeyboxTwin(), KEYBOX_STREAM_HEX)):
            ours, anchor = measure(twin, stream_hex, rounds, repeats, new_values)
            count = rounds * len(stream_hex)
            print(f"  {name}.receive {spread([count / t for t in ours])}   python-canopen "
                  f"SdoServer {spread([count / t for t in anchor])}   ratio "
                  f"{ratio_text(ours, anchor)}")
