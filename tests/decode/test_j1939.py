"""The keypad's J1939 frames decoded: every example frame of spec/pkp-2600-si-j1939.md."""

from __future__ import annotations

from pathlib import Path

import pytest
from click.testing import CliRunner
from hypothesis import given
from hypothesis import strategies as st

from blinkcan.cli.main import cli
from blinkcan.decode import Decoder, Kind
from blinkcan.decode.view import BusView
from blinkcan.formats.pcap import read_pcap, write_pcap
from blinkcan.protocol import Frame
from tests.conftest import frame


@pytest.fixture
def decoder() -> Decoder:
    return Decoder()


@pytest.mark.parametrize(("text", "meaning"), [
    # from the keypad (§6, §11, §18, §19)
    ("18EFFF21 04 1B 01 01 01 21 FF FF", "keypad 21h: key 1 pressed"),
    ("18EFFF21 04 1B 01 01 00 21 FF FF", "keypad 21h: key 1 released"),
    ("18EFFF21 04 1B 01 0C 01 21 FF FF", "keypad 21h: key 12 pressed"),
    ("18EFFF21 04 1B F9 03 80 00 FF 21", "keypad 21h: heartbeat 3, keys held: 8"),
    ("18EFFF21 04 1B F9 03 00 08 FF 21", "keypad 21h: heartbeat 3, keys held: 12"),
    ("18EFFF21 00 03 01 01 02 FF FF FF", "keypad 21h: acknowledged: LED 1 alternates red/green"),
    ("18EFFF21 04 1B 2A 56 32 2E 36 00", "keypad 21h: software revision V2.6"),
    ("18EEFF21 3F 42 6F 1A 00 82 3C C0",
     "keypad 21h: address claim 21h, NAME 3F 42 6F 1A 00 82 3C C0"),
    # to the keypad (§7a-§27)
    ("18EF2100 04 1B 01 01 01 01 00 FF", "keypad 21h: LED 1 red"),
    ("18EF2100 04 1B 01 01 00 00 00 FF", "keypad 21h: LED 1 off"),
    ("18EF2100 04 1B 01 02 03 02 00 FF", "keypad 21h: LED 2 blinks blue"),
    ("18EF2100 04 1B 01 06 01 01 00 FF", "keypad 21h: LED 6 red"),
    ("18EF2100 04 1B 01 08 02 01 00 FF", "keypad 21h: LED 8 green"),
    ("18EF2100 04 1B 01 0B 01 03 02 FF", "keypad 21h: LED 11 alternates red/green"),
    ("18EF2100 04 1B 01 01 01 03 02 FF", "keypad 21h: LED 1 alternates red/green"),
    ("18EF2100 04 1B 02 20 FF FF FF FF", "keypad 21h: led brightness 32/63 until power-off"),
    ("18EF2100 04 1B 03 10 FF FF FF FF", "keypad 21h: backlight level 16/63 until power-off"),
    ("18EF2100 04 1B 28 01 FF FF FF FF", "keypad 21h: key message at start-up on"),
    ("18EF2100 04 1B 2A FF FF FF FF FF", "keypad 21h: software revision request"),
    ("18EF2100 04 1B 34 02 FF FF FF FF", "keypad 21h: startup led show fast flash"),
    ("18EF2100 04 1B 37 02 FF FF FF FF",
     "keypad 21h: led management mode single and multiple LED commands"),
    ("18EF2100 04 1B 6E 00 FF FF FF FF", "keypad 21h: destination address of key messages 00h"),
    ("18EF2100 04 1B 6F 02 FF FF FF FF", "keypad 21h: baud rate 500 kbit/s"),
    ("18EF2100 04 1B 70 02 01 FF FF FF",
     "keypad 21h: source address and keypad identifier: 02h, 01h"),
    ("18EF2100 04 1B 71 01 FF FF FF FF", "keypad 21h: periodic key state on"),
    ("18EF2100 04 1B 72 00 FF FF FF FF", "keypad 21h: event key state off"),
    ("18EF2100 04 1B 73 01 FF FF FF FF", "keypad 21h: led acknowledge on"),
    ("18EF2100 04 1B 74 01 FF FF FF FF", "keypad 21h: address claim at boot on"),
    ("18EF2100 04 1B 75 01 32 FF FF FF", "keypad 21h: heartbeat: on, 500 ms"),
    ("18EF2100 04 1B 77 0A FF FF FF FF", "keypad 21h: key message period 100 ms"),
    ("18EF2100 04 1B 7A 01 FF FF FF FF", "keypad 21h: demo mode at the next power-on on"),
    ("18EF2100 04 1B 7B 20 FF FF FF FF", "keypad 21h: backlight level at start-up 32/63"),
    ("18EF2100 04 1B 7C 10 FF FF FF FF", "keypad 21h: led brightness at start-up 16/63"),
    ("18EF2100 04 1B 7D 02 FF FF FF FF", "keypad 21h: backlight colour green"),
    ("18EF2100 04 1B 80 00 FF FF FF FF", "keypad 21h: switch to CANopen (§27, PKP §44)"),
    # §7b
    ("18A72100 11 01 00 00 00 00 FF FF", "keypad 21h: LEDs colour 1: red 1, 2, 3"),
    ("18A62100 00 00 00 00 00 96 FF FF",
     "keypad 21h: LEDs colour 2: magenta 11; yellow/green 12"),
    ("18A72100 22 22 22 22 22 22 FF FF",
     "keypad 21h: LEDs colour 1: green 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12"),
    # J-2: malformed, and what is not the keypad's
    ("18EF2100 04 1B 01 0D 01 01 00 FF", "keypad 21h: malformed command (the keypad ignores it)"),
    ("0CF00400 00 00 00 00 00 00 00 00", "extended frame 0CF00400h"),
])
def test_spec_frames_decode_to_their_meaning(decoder: Decoder, text: str, meaning: str) -> None:
    event = decoder.decode(frame(text))
    assert str(event) == meaning
    assert (event.kind is Kind.J1939) == (event.kind is not Kind.FRAME)


def test_a_moved_keypad_is_followed(decoder: Decoder) -> None:
    decoder.decode(frame("18EF2100 04 1B 70 02 01 FF FF FF"))
    assert str(decoder.decode(frame("18EFFF02 04 1B 01 05 01 01 FF FF"))) == \
        "keypad 02h: key 5 pressed"
    decoder.decode(frame("18EEFF22 3F 42 6F 1A 00 82 3C C0"))  # claimed after a conflict
    assert str(decoder.decode(frame("18EFFF22 04 1B 01 05 00 21 FF FF"))) == \
        "keypad 22h: key 5 released"
    # a software revision reply names a keypad at any address (scan's answer)
    assert str(decoder.decode(frame("18EFFF30 04 1B 2A 56 32 2E 36 00"))) == \
        "keypad 30h: software revision V2.6"


def test_json_has_the_fields(decoder: Decoder) -> None:
    event = decoder.decode(frame("18EFFF21 04 1B 01 05 01 21 FF FF"))
    assert event.to_json()["key"] == 5
    assert event.to_json()["pressed"] is True
    assert event.to_json()["protocol"] == "j1939"


@given(st.integers(0, 0x1FFFFFFF), st.binary(max_size=8))
def test_random_extended_frames_decode(can_id: int, data: bytes) -> None:
    decoder = Decoder()
    event = decoder.decode(Frame(can_id, data, extended=True))
    assert event.text
    assert decoder.json_line(Frame(can_id, data, extended=True))


def test_a_pcap_keeps_the_29_bit_frames_and_decode_reads_them(tmp_path: Path) -> None:
    """pcap (SocketCAN link type, EFF flag) keeps J1939 identifiers; ``blinkcan decode``
    names what the keypad did."""
    frames = [(0.0, frame("18EF2100 04 1B 01 0B 01 03 02 FF")),
              (0.5, frame("18EFFF21 04 1B 01 05 01 21 FF FF")),
              (1.0, frame("18EFFF21 04 1B F9 00 10 00 FF 21"))]
    path = tmp_path / "j1939.pcap"
    with path.open("wb") as stream:
        write_pcap(stream, frames)
    with path.open("rb") as stream:
        assert [f for _, f in read_pcap(stream)] == [f for _, f in frames]
    result = CliRunner().invoke(cli, ["decode", str(path)])
    assert result.exit_code == 0, result.output
    assert "keypad 21h: LED 11 alternates red/green" in result.output
    assert "keypad 21h: key 5 pressed" in result.output
    assert "keypad 21h: heartbeat 0, keys held: 5" in result.output


def test_the_monitor_view_follows_a_j1939_keypad() -> None:
    decoder = Decoder()
    view = BusView(decoder)
    for text in ("18EF2100 04 1B 01 0B 01 03 02 FF",  # LED 11 alternates red/green
                 "18EF2100 04 1B 01 02 03 02 00 FF",  # LED 2 blinks blue
                 "18EFFF21 04 1B 01 05 01 21 FF FF",  # key 5 pressed
                 "18EFFF21 04 1B 01 07 01 21 FF FF"):
        view.update(decoder.decode(frame(text)))
    keypad = view.nodes[0x21]
    assert (keypad.device, keypad.state, keypad.held) == ("keypad", "J1939", [5, 7])
    phases = {key: (a, b) for key, a, b in keypad.key_phases()}
    assert phases[11] == ("red", "green")
    assert phases[2] == ("blue", "off")
    view.update(decoder.decode(frame("18EFFF21 04 1B F9 00 40 00 FF 21")))  # heartbeat: key 7
    assert keypad.held == [7]
