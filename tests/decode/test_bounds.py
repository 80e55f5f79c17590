"""The decoder stays bounded: caches, routes and SDO transfers never grow without limit, and
the fast JSON writer says exactly what the Event says."""

from __future__ import annotations

import json
import random
import tracemalloc
from collections.abc import Callable

from blinkcan.decode import Decoder, Kind
from blinkcan.decode.decoder import TRANSFER_IDLE_S, TRANSFER_MAX_BYTES, json_time
from blinkcan.devices.registry import describe_device
from blinkcan.protocol import Frame
from tests.conftest import frame


def _growth(feed: Callable[[], None]) -> int:
    """Bytes still allocated after ``feed`` ran (traced by tracemalloc)."""
    tracemalloc.start()
    try:
        before = tracemalloc.get_traced_memory()[0]
        feed()
        return tracemalloc.get_traced_memory()[0] - before
    finally:
        tracemalloc.stop()


def test_distinct_extended_identifiers_do_not_grow_the_decoder() -> None:
    decoder = Decoder()
    decoder.json_line(Frame(0x18FEF100, bytes(8), True))

    def feed() -> None:
        for ident in range(0x100000, 0x100000 + 20_000):
            decoder.json_line(Frame(ident, bytes(8), True), 1.0)
            decoder.decode(Frame(ident + 0x200000, bytes(8), True), 1.0)

    assert _growth(feed) < 256 * 1024  # main kept a route per identifier: megabytes


def _random_pdos(count: int, seed: int = 3) -> list[Frame]:
    chance = random.Random(seed)
    layouts = [(layout, d.default_node_id) for d in (describe_device("keypad"),
                                                      describe_device("keybox"))
               for layout in d.pdos]
    found = []
    for _ in range(count):
        layout, node = chance.choice(layouts)
        values = {s.name: chance.getrandbits(s.length) for s in layout.signals}
        found.append(Frame(layout.cob_id(node), layout.encode(values)))
    return found


def test_the_json_cache_is_bounded_on_traffic_that_never_repeats() -> None:
    decoder = Decoder({0x15: "keypad", 0x0C: "keybox"})
    pdos = _random_pdos(100_000)

    def feed() -> None:
        for n, pdo in enumerate(pdos):
            decoder.json_line(pdo, n * 0.001)

    assert _growth(feed) < 8 * 1024 * 1024  # main cached 100k lines: tens of megabytes


def test_fast_json_lines_are_the_events_json_exactly() -> None:
    fast = Decoder({0x15: "keypad", 0x0C: "keybox"})
    slow = Decoder({0x15: "keypad", 0x0C: "keybox"})
    pdos = [*_random_pdos(3_000, seed=5), frame("215 01"), frame("195 08 00")]  # short ones
    for n, pdo in enumerate(pdos + pdos):  # twice: the second time from the cache
        time = 1_700_000_000 + n / 1000
        line = fast.json_line(pdo, time)
        assert line == json.dumps(slow.decode(pdo, time).to_json(), separators=(",", ":"),
                                  ensure_ascii=False)


def test_an_unterminated_segmented_upload_is_dropped_after_silence() -> None:
    decoder = Decoder({0x15: "keypad"})
    opened = [decoder.decode(frame(t), 0.0) for t in (
        "615 40 08 10 00 00 00 00 00", "595 41 08 10 00 0B 00 00 00",
        "615 60 00 00 00 00 00 00 00", "595 00 42 6C 69 6E 6B 4D 61")]
    assert opened[-1].kind is Kind.SDO_SEGMENT
    # the client gave up; much later an unrelated last segment is not this transfer's end
    late = decoder.decode(frame("595 0B 72 69 6E 65 00 00 00"), TRANSFER_IDLE_S + 1.0)
    assert late.kind is Kind.FRAME
    assert "SDO value" not in str(late)


def test_an_endless_segmented_transfer_is_no_longer_followed_past_the_limit() -> None:
    decoder = Decoder({0x15: "keypad"})
    decoder.decode(frame("615 40 08 10 00 00 00 00 00"), 0.0)
    decoder.decode(frame("595 41 08 10 00 00 00 00 00"), 0.0)
    events = [decoder.decode(frame(f"595 {(n % 2) << 4:02X} 41 41 41 41 41 41 41"), n * 0.001)
              for n in range(TRANSFER_MAX_BYTES // 7 + 10)]
    assert "no longer followed" in str(events[TRANSFER_MAX_BYTES // 7])
    assert events[-1].kind is Kind.FRAME  # the transfer is gone: nothing accumulates


def test_other_ecus_frames_are_written_as_their_events_say() -> None:
    """Frames no device sends are skipped by their id (issue 22); their lines stay exactly
    what their events say, also once a node's model is learned (then its frames are named)."""
    from blinkcan.decode.decoder import _encode

    fast, plain, text = Decoder(), Decoder(), Decoder()
    others = [Frame(0x0A2, b"\x01\x02"), Frame(0x0CF00400, bytes(8), True),
              Frame(0x18FEF117, b"\x01" * 8, True), Frame(0x0A2, b"\x03")]
    learn = [frame("622 40 00 10 00 00 00 00 00"), frame("5A2 43 00 10 00 91 01 0B 00")]
    seen: list[str] = []
    looked_up = 0
    for n, item in enumerate(others * 2 + learn + others * 2):
        line = fast.json_line(item, n / 4)
        event = plain.decode(item, n / 4)
        assert line == _encode(event.to_json())
        assert text.text(item, n / 4) == str(event)
        undecoded = text.undecoded(item.can_id, item.extended)
        if undecoded is not None:  # what decode says, without the Event
            assert event.kind is Kind.FRAME
            assert not event.fields
            assert undecoded == (str(event), event.node_id, event.device)
            looked_up += 1
        seen.append(str(event))
    assert seen[0] == "node 22h: frame 0A2h"
    assert seen[1] == "extended frame 0CF00400h"
    assert seen[-1] == "keypad 22h: frame 0A2h"  # 1000h named the node's model
    assert looked_up >= len(others)


def test_a_keypad_pgn_from_a_learned_address_is_still_decoded() -> None:
    """Only PGNs the keypad never uses are skipped by id: a keypad learned at a new address is
    decoded on an identifier seen before it was learned."""
    decoder = Decoder()
    heartbeat = Frame(0x18EFFF30, bytes((0x04, 0x1B, 0xF9, 0x07, 0x00, 0x00, 0xFF, 0x30)), True)
    command = Frame(0x18EF3000, bytes((0x04, 0x1B, 0x02, 0x20, 0xFF, 0xFF, 0xFF, 0xFF)), True)
    assert decoder.decode(command).kind is Kind.FRAME  # 30h is not known as a keypad yet
    assert decoder.decode(heartbeat).kind is Kind.J1939  # §18: only a keypad sends it
    assert decoder.decode(command).kind is Kind.J1939
    assert json.loads(decoder.json_line(command))["kind"] == "j1939"


def test_a_kept_j1939_meaning_changes_when_a_keypad_address_is_learned() -> None:
    """A J1939 frame's meaning depends on which addresses are keypads: one kept from before
    an address was learned is not used after it."""
    fast, plain = Decoder(), Decoder()
    command = Frame(0x18EFFF30, bytes((0x04, 0x1B, 0x02, 0x20, 0xFF, 0xFF, 0xFF, 0xFF)), True)
    heartbeat = Frame(0x18EFFF30, bytes((0x04, 0x1B, 0xF9, 0x07, 0x00, 0x00, 0xFF, 0x30)), True)
    kinds = []
    for n, item in enumerate([command, command, heartbeat, command, command]):
        event = plain.decode(item, n / 4)
        assert fast.json_line(item, n / 4) == _encode_event(event)
        kinds.append(event.kind)
    # from 30h, not yet a keypad, to all: a command to the keypads; once 30h is a keypad (its
    # heartbeat), the same frame is its message, one the decoder does not know
    assert kinds == [Kind.J1939, Kind.J1939, Kind.J1939, Kind.FRAME, Kind.FRAME]


def test_kept_sdo_events_follow_the_transfer() -> None:
    """An upload response seen before means its value again only in a live transfer of the
    same object: after the idle time, or to a read of another object, it is an unexplained
    reply."""
    fast, plain = Decoder({0x15: "keypad"}), Decoder({0x15: "keypad"})
    read, value = frame("615 40 17 10 00 00 00 00 00"), frame("595 4B 17 10 00 F4 01 00 00")
    other = frame("615 40 00 18 01 00 00 00 00")
    script = [(read, 0.0), (value, 0.1), (read, 1.0), (value, 1.1), (other, 2.0), (value, 2.1),
              (read, 3.0), (value, 3.0 + TRANSFER_IDLE_S + 1)]
    texts = []
    for item, time in script:
        event = plain.decode(item, time)
        assert fast.json_line(item, time) == _encode_event(event)
        texts.append(str(event))
    assert texts[3] == "keypad 15h: SDO value 1017h/00 Producer heartbeat time = 1F4h"
    # a reply for 1017h/00 to a read of 1800h/01 is not 1800h/01's value (CiA 301 §7.2.4.3.6:
    # the reply names its object); main said "SDO value 1800h/01 ... = 1F4h"
    assert texts[5] == "keypad 15h: SDO reply 4Bh"
    assert texts[7] == "keypad 15h: SDO reply 4Bh"


def _encode_event(event: object) -> str:
    from blinkcan.decode.decoder import Event, _encode

    assert isinstance(event, Event)
    return _encode(event.to_json())


def test_every_fast_line_writes_its_time_as_the_events_json_does() -> None:
    """The fast lines write the time as an event's JSON does (a plain decimal: 0.00002, never
    2e-05; tests/decode/test_json_time.py), byte for byte, the rest as the standard json
    module does, at every magnitude a log's time takes (relative from 0, epoch seconds,
    nanoseconds)."""
    chance = random.Random(11)
    times = [0.0, 1e-4, 0.5, 1.0, 1_700_000_000.0, 1_700_000_000.000_4, 9_999_999_999_999_998.0,
             1e16, 1.7e18, -2.5] + [10 ** chance.uniform(-4, 16) for _ in range(400)]
    fast, plain = (Decoder({0x15: "keypad", 0x0C: "keybox"}) for _ in range(2))
    read, value = frame("615 40 17 10 00 00 00 00 00"), frame("595 4B 17 10 00 F4 01 00 00")
    j1939 = Frame(0x18EFFF21, bytes((0x04, 0x1B, 0x02, 0x20, 0xFF, 0xFF, 0xFF, 0xFF)), True)
    others = [Frame(0x0A2, b"\x01\x02"), Frame(0x0CF00400, bytes(8), True), frame("70C 05"),
              read, value, j1939, *_random_pdos(4, seed=9)]
    for time in times:
        for item in others:  # each seen before from the second time on: the cached lines
            event = plain.decode(item, time)
            document = event.to_json()
            standard = json.dumps({**document, "time": 0}, separators=(",", ":"),
                                  ensure_ascii=False)
            zero = '{"time":0'
            assert fast.json_line(item, time) == \
                '{"time":' + json_time(time) + standard[len(zero):], (time, item)
