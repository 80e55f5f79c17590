"""The decoder: manual example frames to their documented meaning, learning, JSON."""

from __future__ import annotations

import json

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from blinkcan.decode import Decoder, Kind
from blinkcan.protocol import Frame
from tests.conftest import frame


def decoded(decoder: Decoder, *texts: str) -> list[str]:
    return [str(decoder.decode(frame(t))) for t in texts]


@pytest.fixture
def decoder() -> Decoder:
    return Decoder({0x15: "keypad", 0x0C: "keybox"})


@pytest.mark.parametrize(("text", "meaning"), [
    # PKP §4-§8, KBX §11-§15
    ("000 01 15", "NMT start, keypad 15h"),
    ("000 80 0C", "NMT enter pre-operational, keybox 0Ch"),
    ("000 81 15", "NMT reset node, keypad 15h"),
    ("000 02 00", "NMT stop, all nodes"),
    ("000 00 15", "NMT stop (legacy 00h), keypad 15h"),
    ("715 00", "keypad 15h: boot-up"),
    ("70C 7F", "keybox 0Ch: heartbeat, pre-operational"),
    ("715 05", "keypad 15h: heartbeat, operational"),
    # PKP §11: "Red LED #2 and #7 ON", "Green LED #1 and red LED #9 on", "Blue LED #4 and #8"
    ("215 42 00 00 00 00 00 00 00", "keypad 15h: LEDs on: red 2, 7"),
    ("215 00 11 00 00 00 00 00 00", "keypad 15h: LEDs on: red 9; green 1"),
    ("215 00 00 00 88 00 00 00 00", "keypad 15h: LEDs on: blue 4, 8"),
    ("215 00 CC 00 00 00 00 00 00", "keypad 15h: LEDs on: red 11, 12; green 3, 4"),
    ("215 00 00 00 00 00 00 00 00", "keypad 15h: LEDs on: none"),
    # PKP §12
    ("315 00 00 CC 00 03 00 00 00", "keypad 15h: LEDs blink: green 7, 8, 11, 12; blue 9, 10"),
    ("315 09 00 00 00 00 00 00 00", "keypad 15h: LEDs blink: red 1, 4"),
    # PKP §13/§14
    ("415 10 00 00 00 00 00 00 00", "keypad 15h: indicator brightness 16/63"),
    ("515 00 00 00 00 00 00 00 00", "keypad 15h: backlight brightness 0/63"),
    # KBX §17/§18
    ("20C 81 00 00 00 00 00 00 00", "keybox 0Ch: outputs OFF: 1, 8; HIGH: none"),
    ("20C 00 00 00 03 00 00 00 00", "keybox 0Ch: outputs OFF: none; HIGH: 9, 10"),
    ("20C 01 00 02 00 00 00 00 00", "keybox 0Ch: outputs OFF: 1; HIGH: 2"),
    ("18C 18 00 00 00 00 00 00 00", "keybox 0Ch: outputs in FAULT: 4, 5"),
    ("18C 00 01 00 00 00 00 00 00", "keybox 0Ch: outputs in FAULT: 9"),
    ("18EF2100 04 1B 80 00 FF FF FF FF", "keypad 21h: switch to CANopen (§27, PKP §44)"),
])
def test_manual_frames_decode_to_their_meaning(decoder: Decoder, text: str, meaning: str) -> None:
    assert str(decoder.decode(frame(text))) == meaning


def test_key_state_says_which_keys_went_down_and_up(decoder: Decoder) -> None:
    # PKP §10: "Keys #6 and #1 pressed", then "Only key #12 pressed"
    assert decoded(decoder, "195 21 00 00 00 04", "195 00 08 00 00 05", "195 00 08 00 00 06") == [
        "keypad 15h: key 1, 6 pressed",
        "keypad 15h: key 12 pressed; key 1, 6 released",
        "keypad 15h: keys held: 12",
    ]


def test_sdo_exchanges_with_object_names_and_values(decoder: Decoder) -> None:
    assert decoded(decoder,
                   "615 40 00 20 01 00 00 00 00", "595 4B 00 20 01 FF 0F 00 00",
                   "615 2B 17 10 00 F4 01 00 00", "595 60 17 10 00 00 00 00 00",
                   "60C 23 11 10 01 6C 6F 61 64", "58C 43 11 10 01 00 00 00 00",
                   "615 40 01 10 00 00 00 00 00", "595 80 01 10 00 00 00 02 06") == [
        "keypad 15h: SDO read 2000h/01 Keys pressed",
        "keypad 15h: SDO value 2000h/01 Keys pressed = FFFh",
        "keypad 15h: SDO write 1017h/00 Producer heartbeat time = 1F4h",
        "keypad 15h: SDO write 1017h/00 Producer heartbeat time done",
        "keybox 0Ch: SDO write 1011h/01 Restore all default parameters = 64616F6Ch",
        "keybox 0Ch: SDO write 1011h/01 Restore all default parameters done",  # errata K3
        "keypad 15h: SDO read 1001h/00",
        "keypad 15h: SDO abort 1001h/00: 06020000h object does not exist in the object "
        "dictionary",
    ]


def test_segmented_uploads_are_reassembled(decoder: Decoder) -> None:
    events = [decoder.decode(frame(t)) for t in (
        "615 40 08 10 00 00 00 00 00", "595 41 08 10 00 0B 00 00 00",
        "615 60 00 00 00 00 00 00 00", "595 00 42 6C 69 6E 6B 4D 61",
        "615 70 00 00 00 00 00 00 00", "595 17 72 69 6E 65 00 00 00")]
    assert [e.kind for e in events] == [Kind.SDO_READ, Kind.SDO_SEGMENT, Kind.SDO_SEGMENT,
                                        Kind.SDO_SEGMENT, Kind.SDO_SEGMENT, Kind.SDO_VALUE]
    assert events[-1].fields["value"] == "BlinkMarine"


def test_the_j1939_switch_request(decoder: Decoder) -> None:
    assert decoder.decode(frame("615 2B FF 20 01 01")).kind is Kind.J1939


def test_unknown_nodes_are_learned_from_identity_traffic() -> None:
    decoder = Decoder()
    assert str(decoder.decode(frame("18C 08 00 00 00 00 00 00 00"))) == "node 0Ch: frame 18Ch"
    decoded(decoder, "60C 40 00 10 00 00 00 00 00", "58C 43 00 10 00 91 01 03 00")
    assert str(decoder.decode(frame("18C 08 00 00 00 00 00 00 00"))) == \
        "keybox 0Ch: outputs in FAULT: 4"
    decoded(decoder, "61A 40 0B 10 00 00 00 00 00", "59A 41 0B 10 00 09 00 00 00",
            "61A 60 00 00 00 00 00 00 00", "59A 00 50 4B 50 32 36 30 30",
            "61A 70 00 00 00 00 00 00 00", "59A 1B 53 49 00 00 00 00 00")
    assert decoder.device(0x1A) is not None
    assert decoder.device(0x1A).kind == "keypad"  # type: ignore[union-attr]


def test_json_form_is_one_object_with_the_meaning(decoder: Decoder) -> None:
    event = decoder.decode(frame("18C 18 00 00 00 00 00 00 00"), 12.5)
    document = json.loads(json.dumps(event.to_json()))
    assert document == {"time": 12.5, "id": 0x18C, "extended": False,
                        "data": "1800000000000000", "kind": "pdo", "node": 12,
                        "device": "keybox", "text": "keybox 0Ch: outputs in FAULT: 4, 5",
                        "pdo": "faults", "faults": [4, 5]}


@pytest.mark.parametrize(("spec", "message"), [
    ("toaster", r"known: pkp-2600-si \(keypad\), keybox"),
    ("keybox@2", "keybox generations are 1.0, not '2'"),
    ("keypad@9.9", "pkp-2600-si generations are 1.1, 1.5")])
def test_unknown_device_names_are_refused(spec: str, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        Decoder({1: spec})


def test_json_lines_equal_the_event_json_cached_or_not() -> None:
    from tests.cli.session import session

    fast, plain = Decoder(), Decoder()
    for _ in range(3):  # the second and third rounds hit the cache for pure frames
        for timestamp, item in session():
            assert json.loads(fast.json_line(item, timestamp + 0.5)) == \
                plain.decode(item, timestamp + 0.5).to_json()


_frames = st.one_of(
    st.builds(lambda keys, tick, short: Frame(0x195, (keys.to_bytes(2, "little") + bytes(2)
                                                       + bytes((tick,)))[: 1 if short else 5]),
              st.integers(0, 0x1FFF), st.integers(0, 3), st.booleans()),
    st.sampled_from([Frame(0x715, b"\x00"), Frame(0x715, b"\x05"), Frame(0x70C, b"\x7f"),
                     Frame(0x215, bytes.fromhex("4200000000000000")),
                     Frame(0x615, bytes.fromhex("4000100000000000")),
                     Frame(0x595, bytes.fromhex("4300100091010B00"))]),
)


@settings(max_examples=200, deadline=None)
@given(st.lists(_frames, max_size=60))
def test_cached_json_lines_always_equal_the_plain_decoding(frames: list[Frame]) -> None:
    fast, plain = Decoder({0x15: "keypad", 0x0C: "keybox"}), Decoder({0x15: "keypad",
                                                                       0x0C: "keybox"})
    for i, item in enumerate(frames * 2):  # the second pass hits the caches
        assert json.loads(fast.json_line(item, i / 8)) == json.loads(
            json.dumps(plain.decode(item, i / 8).to_json()))


def test_generation_2_backlight_frames() -> None:
    decoder = Decoder({0x15: "keypad@1.5"})
    assert decoded(decoder, "515 20 03 00 00 00 00 00 00", "515 10 00", "515 10",
                   "515 40 03") == [
        "keypad 15h: backlight 32/63 in blue",  # rev 1.5 §15: 50 % with blue colour
        "keypad 15h: backlight 16/63 in the default colour",
        "keypad 15h: backlight brightness 16/63",  # DLC 1: the colour is unchanged (G2)
        "keypad 15h: backlight level 40h over 3Fh: ignored",
    ]


def test_a_key_state_frame_without_its_tick_byte(decoder: Decoder) -> None:
    event = decoder.decode(frame("195 01 00"))  # errata P8: DLC >= 2 is a key state
    assert str(event) == "keypad 15h: key 1 pressed"
    assert event.fields["tick"] is None
