"""Property tests: random traffic never crashes the keypad and every SDO request is answered."""

from __future__ import annotations

from hypothesis import given, settings
from hypothesis import strategies as st

from blinkcan.protocol import Frame
from blinkcan.twin import KeypadTwin

ids = st.one_of(st.sampled_from([0x000, 0x080, 0x215, 0x315, 0x415, 0x515, 0x615, 0x715]),
                st.integers(0, 0x7FF))
frames = st.builds(Frame, ids, st.binary(max_size=8))
sdo_requests = st.builds(
    lambda command, index, sub, data: Frame(0x615, bytes((command,)) + index.to_bytes(2, "little")
                                            + bytes((sub,)) + data),
    st.sampled_from([0x40, 0x2F, 0x2B, 0x27, 0x23, 0x22, 0x21, 0x60, 0x70, 0x80, 0xA0, 0x00]),
    st.one_of(st.sampled_from([0x1000, 0x1008, 0x1017, 0x1800, 0x2001, 0x2003, 0x2013, 0x20FF]),
              st.integers(0, 0xFFFF)),
    st.integers(0, 0xFF),
    st.binary(min_size=4, max_size=4),
)


@settings(max_examples=300, deadline=None)
@given(st.lists(frames, max_size=40), st.booleans())
def test_random_frames_never_raise(traffic: list[Frame], start: bool) -> None:
    twin = KeypadTwin()
    twin.power_on(0.0)
    if start:
        twin.receive(Frame(0, b"\x01\x15"), 0.0)
    for i, frame in enumerate(traffic):
        for reply in twin.receive(frame, i * 0.01):
            assert isinstance(reply, Frame)
        twin.advance(i * 0.01)
    twin.snapshot()


@settings(max_examples=300, deadline=None)
@given(st.lists(sdo_requests, min_size=1, max_size=30), st.booleans())
def test_every_sdo_request_gets_exactly_one_reply(requests: list[Frame], start: bool) -> None:
    twin = KeypadTwin()
    twin.power_on(0.0)
    if start:
        twin.receive(Frame(0, b"\x01\x15"), 0.0)
    for request in requests:
        if request.data[1:4] == b"\xff\x20\x01":
            continue  # the J1939 switch leaves CANopen on purpose
        replies = [f for f in twin.receive(request, 1.0) if f.can_id == 0x595]
        expected = 0 if request.data[0] >> 5 == 4 else 1  # a client abort gets no reply
        assert len(replies) == expected, (request, replies)


@settings(max_examples=100, deadline=None)
@given(st.dictionaries(st.sampled_from(["producer_heartbeat_time", "tpdo1_event_timer",
                                        "default_backlight_colour", "startup_led_show",
                                        "node_id", "baud_rate"]),
                       st.integers(0, 0xFFFF)))
def test_settings_survive_power_cycles(writes: dict[str, int]) -> None:
    twin = KeypadTwin()
    twin.power_on(0.0)
    table = twin.description.table
    for name, value in writes.items():
        entry = table[name]
        size = entry.data_type.size or 4
        command = {1: 0x2F, 2: 0x2B, 4: 0x23}[size]
        raw = (value & ((1 << (8 * size)) - 1)).to_bytes(size, "little")
        data = bytes((command,)) + entry.mux + raw.ljust(4, b"\0")
        twin.receive(Frame(0x600 + twin.node_id, data), 0.0)
    before = twin.snapshot()["settings"]
    twin.power_off()
    twin.power_on(1.0)
    assert twin.snapshot()["settings"] == before
