"""The keypad in J1939 mode: every example frame of spec/pkp-2600-si-j1939.md (both directions)
and its decisions J-1..J-7, on both firmware generations. § numbers are Blink's J1939 manual's.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from blinkcan.devices.keypad_j1939 import BITRATES, COMMANDS, Persistence
from blinkcan.protocol import Frame
from blinkcan.protocol.j1939 import J1939Name, address_claim_frame
from blinkcan.twin import KeypadTwin, NvmError
from tests.conftest import frame
from tests.twin.trace import Bench

NAME = "3F 42 6F 1A 00 82 3C C0"


@pytest.fixture(params=["1.1", "1.5"])
def manual(request: pytest.FixtureRequest) -> str:
    return str(request.param)


@pytest.fixture
def bench(manual: str) -> Bench:
    """A keypad built in J1939 mode at its defaults, powered, startup show over."""
    bench = Bench(KeypadTwin(manual=manual, protocol="j1939"))
    bench.replay("""
        on
        < -                          # §5: address claim off, heartbeat off: silent
        wait 10
    """)
    return bench


def snapshot(bench: Bench) -> dict[str, Any]:
    return bench.twin.snapshot()


def look(bench: Bench, key: int) -> tuple[str, list[str]]:
    entry = snapshot(bench)["keys"][key - 1]
    return entry["colour"], entry["phases"]


def power_cycle(bench: Bench) -> None:
    bench.replay("""
        off
        on
    """)


# -- messages from the keypad (§6, §11, §18, §19) ---------------------------------------------


def test_s6_key_contact_messages(bench: Bench) -> None:
    bench.replay("""
        press 1
        < 18EFFF21 04 1B 01 01 01 21 FF FF    # key 1 pressed
        release 1
        < 18EFFF21 04 1B 01 01 00 21 FF FF    # key 1 released
        press 12
        < 18EFFF21 04 1B 01 0C 01 21 FF FF    # key 12 pressed
    """)


def test_s18_heartbeat_with_keys_and_counter(bench: Bench) -> None:
    bench.replay("""
        > 18EF2100 04 1B 75 01 32 FF FF FF    # on, 500 ms
        < -
        press 8
        < 18EFFF21 04 1B 01 08 01 21 FF FF
        wait 0.5
        < 18EFFF21 04 1B F9 00 80 00 FF 21
        wait 0.5
        < 18EFFF21 04 1B F9 01 80 00 FF 21
        wait 0.5
        < 18EFFF21 04 1B F9 02 80 00 FF 21
        wait 0.5
        < 18EFFF21 04 1B F9 03 80 00 FF 21    # the printed example: key 8 held
        release 8
        < 18EFFF21 04 1B 01 08 00 21 FF FF
        press 12
        < 18EFFF21 04 1B 01 0C 01 21 FF FF
        wait 0.5
        < 18EFFF21 04 1B F9 04 00 08 FF 21    # key 12 held
        > 18EF2100 04 1B 75 00 FF FF FF FF    # off (FFh: period unchanged, ours)
        wait 2
        < -
    """)


def test_s18_heartbeat_example_key_12_held(bench: Bench) -> None:
    """The spec's second printed heartbeat, byte for byte: counter 03h, key 12 held."""
    bench.replay("""
        > 18EF2100 04 1B 75 01 32 FF FF FF    # on, 500 ms
        press 12
        < 18EFFF21 04 1B 01 0C 01 21 FF FF
        wait 0.5
        < 18EFFF21 04 1B F9 00 00 08 FF 21
        wait 0.5
        < 18EFFF21 04 1B F9 01 00 08 FF 21
        wait 0.5
        < 18EFFF21 04 1B F9 02 00 08 FF 21
        wait 0.5
        < 18EFFF21 04 1B F9 03 00 08 FF 21    # as printed: key 12 held
    """)


def test_j6_heartbeat_counter_wraps(bench: Bench) -> None:
    bench.replay("> 18EF2100 04 1B 75 01 05 FF FF FF")  # every 50 ms
    counters = []
    for _ in range(258):
        bench.now += 0.05
        counters += [f.data[3] for f in bench.twin.advance(bench.now)]
    assert counters[:3] == [0, 1, 2]
    assert counters[254:258] == [0xFE, 0xFF, 0x00, 0x01]


def test_s19_led_acknowledge(bench: Bench) -> None:
    bench.replay("""
        > 18EF2100 04 1B 01 01 01 03 02 FF    # acknowledge off by default (§5)
        < -
        > 18EF2100 04 1B 73 01 FF FF FF FF
        < -
        > 18EF2100 04 1B 01 01 01 03 02 FF
        < 18EFFF21 00 03 01 01 02 FF FF FF    # the printed example
        > 18EF2100 04 1B 37 02 FF FF FF FF
        > 18A72100 11 01 00 00 00 00 FF FF    # not after the multiple-LED frames
        < -
    """)


def test_s11_software_revision(bench: Bench) -> None:
    bench.replay("""
        > 18EF2100 04 1B 2A FF FF FF FF FF
        < 18EFFF21 04 1B 2A 56 32 2E 36 00    # "V2.6", as the sibling manuals print
    """)


# -- LED commands (§7a, §7b), J-4 ---------------------------------------------------------------


def test_s7a_single_led_examples(bench: Bench) -> None:
    bench.replay("> 18EF2100 04 1B 01 01 01 01 00 FF")  # key 1 red
    assert look(bench, 1) == ("red", ["red", "red"])
    bench.replay("> 18EF2100 04 1B 01 01 00 00 00 FF")  # key 1 off
    assert look(bench, 1) == ("off", ["off", "off"])
    bench.replay("> 18EF2100 04 1B 01 02 03 02 00 FF")  # key 2 blinks blue
    assert look(bench, 2) == ("blue", ["blue", "off"])
    bench.replay("> 18EF2100 04 1B 01 06 01 01 00 FF")  # key 6 red
    bench.replay("> 18EF2100 04 1B 01 08 02 01 00 FF")  # key 8 green
    bench.replay("> 18EF2100 04 1B 01 0B 01 03 02 FF")  # key 11 alternates red/green
    assert [look(bench, k)[0] for k in (6, 8)] == ["red", "green"]
    assert look(bench, 11) == ("red", ["red", "green"])  # J-4: the CANopen phase model
    assert snapshot(bench)["keys"][10]["alternate"]


def test_j4_same_picture_as_canopen_mode(bench: Bench) -> None:
    """Key 11 alternating red/green looks as `201 + 202` with red on and red+green blink."""
    canopen = Bench(KeypadTwin())
    canopen.replay("""
        on
        < 715 00
        wait 10
        > 000 01 15
        > 215 00 04 00 00 00 00 00 00
        > 315 00 04 40 00 00 00 00 00
    """)
    bench.replay("> 18EF2100 04 1B 01 0B 01 03 02 FF")
    assert snapshot(bench)["keys"] == canopen.twin.snapshot()["keys"]
    assert snapshot(bench)["leds"] == canopen.twin.snapshot()["leds"]
    assert snapshot(bench)["blink_period_s"] == canopen.twin.snapshot()["blink_period_s"]


def test_s7b_multiple_leds_need_management_mode_02(bench: Bench) -> None:
    bench.replay("> 18A72100 11 01 00 00 00 00 FF FF")
    assert look(bench, 1)[0] == "off"  # §13: single-LED commands only by default
    bench.replay("""
        > 18EF2100 04 1B 37 02 FF FF FF FF
        > 18A72100 11 01 00 00 00 00 FF FF    # LEDs 1-3 red
    """)
    assert [look(bench, k)[0] for k in range(1, 5)] == ["red", "red", "red", "off"]
    bench.replay("> 18A62100 00 00 00 00 00 96 FF FF")  # LED 11 magenta, LED 12 yellow/green
    # issue 20 item 4: 09h is yellow/green, not the yellow of its RGB mixture
    assert [look(bench, k)[0] for k in (1, 11, 12)] == ["red", "magenta", "yellow/green"]
    bench.replay("> 18A72100 22 22 22 22 22 22 FF FF")  # all green (colour 2 of 11, 12 kept)
    assert [look(bench, k)[0] for k in range(1, 11)] == ["green"] * 10
    assert look(bench, 11) == ("green", ["green", "magenta"])  # two colours alternate


def test_s7b_nibble_pairs(bench: Bench) -> None:
    bench.replay("""
        > 18EF2100 04 1B 37 02 FF FF FF FF
        > 18A72100 33 F1 00 00 00 00 FF FF
        > 18A62100 23 02 00 00 00 00 FF FF
    """)
    assert look(bench, 1) == ("blue", ["blue", "off"])  # the same colour twice: blink
    assert look(bench, 2) == ("blue", ["blue", "green"])  # two colours: alternate
    assert look(bench, 3) == ("red", ["red", "green"])
    assert look(bench, 4) == ("off", ["off", "off"])  # Fh with nothing: off (ours)


# -- brightness and backlight (§8, §9, §24-§26) -------------------------------------------------


def test_brightness_and_backlight_are_temporary(bench: Bench) -> None:
    assert snapshot(bench)["indicator_brightness"] == 0x3F
    assert snapshot(bench)["backlight"] == {"colour": "amber", "level": 0}
    bench.replay("""
        > 18EF2100 04 1B 02 20 FF FF FF FF    # §8: 50 %
        > 18EF2100 04 1B 03 10 FF FF FF FF    # §9: 25 %
        > 18EF2100 04 1B 7D 02 FF FF FF FF    # §26: green, stored
    """)
    assert snapshot(bench)["indicator_brightness"] == 0x20
    assert snapshot(bench)["backlight"] == {"colour": "green", "level": 0x10}
    power_cycle(bench)
    assert snapshot(bench)["indicator_brightness"] == 0x3F  # back to the 7Ch value
    assert snapshot(bench)["backlight"] == {"colour": "green", "level": 0}
    bench.replay("""
        > 18EF2100 04 1B 7B 20 FF FF FF FF    # §24
        > 18EF2100 04 1B 7C 10 FF FF FF FF    # §25
    """)
    assert snapshot(bench)["indicator_brightness"] == 0x3F  # at the next start-up
    power_cycle(bench)
    assert snapshot(bench)["indicator_brightness"] == 0x10
    assert snapshot(bench)["backlight"]["level"] == 0x20


# -- settings (§10, §12-§17, §20, §22), J-3 ------------------------------------------------------


def test_s10_key_message_at_startup(bench: Bench) -> None:
    bench.replay("> 18EF2100 04 1B 28 01 FF FF FF FF\n< -")
    bench.replay("off")
    bench.now += 1
    frames = bench.twin.power_on(bench.now)
    assert frames == [frame(f"18EFFF21 04 1B 01 {key:02X} 00 21 FF FF") for key in range(1, 13)]


def test_s12_startup_led_show(bench: Bench) -> None:
    bench.replay("> 18EF2100 04 1B 34 02 FF FF FF FF")
    power_cycle(bench)
    assert snapshot(bench)["startup_show"] == {"mode": "fast flash", "step": 0}
    assert look(bench, 1)[0] == "white"
    bench.replay("wait 5")
    assert snapshot(bench)["startup_show"] is None


def test_s14_destination_address(bench: Bench) -> None:
    bench.replay("""
        > 18EF2100 04 1B 6E 00 FF FF FF FF
        press 3
        < 18EF0021 04 1B 01 03 01 21 FF FF
        > 18EF2100 04 1B 6E FE FF FF FF FF    # FEh reserved: no change
        release 3
        < 18EF0021 04 1B 01 03 00 21 FF FF
    """)


def test_s15_baud_rate_at_the_next_power_on(bench: Bench) -> None:
    assert snapshot(bench)["bitrate"] == 250_000
    bench.replay("> 18EF2100 04 1B 6F 02 FF FF FF FF")
    assert snapshot(bench)["bitrate"] == 250_000  # J-3
    bench.replay("> 18EF2100 04 1B 6F 05 FF FF FF FF")  # other values: no change
    power_cycle(bench)
    assert snapshot(bench)["bitrate"] == 500_000


def test_s16_source_address_and_identifier_at_once(bench: Bench) -> None:
    bench.replay("""
        > 18EF2100 04 1B 70 02 01 FF FF FF    # SA 02h, identifier 01h (J-3: at once)
        press 1
        < 18EFFF02 04 1B 01 01 01 01 FF FF
        > 18EF2100 04 1B 2A FF FF FF FF FF    # the old address is another node's now
        < -
        > 18EF0200 04 1B 70 FF 07 FF FF FF    # FFh: SA unchanged
        release 1
        < 18EFFF02 04 1B 01 01 00 07 FF FF
        > 18EF0200 04 1B 70 FE 08 FF FF FF    # invalid SA: no change at all
        press 1
        < 18EFFF02 04 1B 01 01 01 07 FF FF
    """)
    power_cycle(bench)
    assert snapshot(bench)["j1939"]["source_address"] == 0x02  # stored


def test_s17_periodic_and_event_key_state(bench: Bench) -> None:
    bench.replay("""
        > 18EF2100 04 1B 72 00 FF FF FF FF    # no event messages
        press 5
        < -
        > 18EF2100 04 1B 71 01 FF FF FF FF    # periodic, 100 ms by default
        > 18EF2100 04 1B 77 0A FF FF FF FF
        wait 0.05
        < -
    """)
    bench.now += 0.05
    frames = bench.twin.advance(bench.now)  # J-7: keys 1-12 in order, one frame each
    assert frames == [frame(f"18EFFF21 04 1B 01 {key:02X} {int(key == 5):02X} 21 FF FF")
                      for key in range(1, 13)]
    bench.replay("""
        > 18EF2100 04 1B 77 04 FF FF FF FF    # below 05h: no change
        wait 0.05
        < -
    """)
    bench.now += 0.05
    assert len(bench.twin.advance(bench.now)) == 12


def test_s22_demo_mode(bench: Bench) -> None:
    bench.replay("> 18EF2100 04 1B 7A 01 FF FF FF FF")
    assert snapshot(bench)["demo"] is None  # entered at the next power-on
    power_cycle(bench)
    bench.replay("wait 10")
    assert snapshot(bench)["backlight"]["colour"] == "red"  # appendix: red on entry
    bench.replay("""
        press 1
        < 18EFFF21 04 1B 01 01 01 21 FF FF
    """)
    assert snapshot(bench)["backlight"]["colour"] == "green"
    bench.replay("> 18EF2100 04 1B 03 10 FF FF FF FF")  # any other command leaves it
    assert snapshot(bench)["demo"] is None
    assert snapshot(bench)["backlight"] == {"colour": "amber", "level": 0x10}
    power_cycle(bench)
    assert snapshot(bench)["demo"] is not None  # still stored
    bench.replay("> 18EF2100 04 1B 7A 00 FF FF FF FF")
    power_cycle(bench)
    assert snapshot(bench)["demo"] is None


# -- address claim (§20), J-5 -------------------------------------------------------------------


def claiming(bench: Bench) -> None:
    bench.replay(f"""
        > 18EF2100 04 1B 74 01 FF FF FF FF
        off
        on
        < 18EEFF21 {NAME}                  # §20: NAME at start-up
    """)


def test_s20_address_claim_at_boot(bench: Bench) -> None:
    claiming(bench)
    assert snapshot(bench)["j1939"]["address_claim"] == "claiming"
    bench.replay("wait 0.25")
    assert snapshot(bench)["j1939"]["address_claim"] == "claimed"
    bench.replay(f"""
        > 18EAFF00 00 EE 00                  # request for address claimed
        < 18EEFF21 {NAME}
    """)


def test_j5_a_stronger_claim_moves_the_keypad_up(bench: Bench) -> None:
    claiming(bench)
    bench.replay(f"""
        > 18EEFF21 00 00 00 00 00 00 00 80   # a lower NAME claims 21h
        < 18EEFF22 {NAME}                    # the next address upwards
        wait 0.25
        press 1
        < 18EFFF22 04 1B 01 01 01 21 FF FF
        > 18EF2200 04 1B 2A FF FF FF FF FF
        < 18EFFF22 04 1B 2A 56 32 2E 36 00
        > 18EEFF22 FF FF FF FF FF FF FF FF   # a higher NAME: the keypad defends 22h
        < 18EEFF22 {NAME}
    """)
    assert snapshot(bench)["j1939"]["source_address"] == 0x22
    bench.replay(f"""
        off
        on
        < 18EEFF21 {NAME}                    # the stored address is claimed again (ours)
    """)


def test_j5_cannot_claim_goes_silent(bench: Bench) -> None:
    claiming(bench)
    stronger = J1939Name(0)
    for address in range(1, 0xFE):
        if address != 0x21:
            assert bench.twin.receive(address_claim_frame(stronger, address), bench.now) == []
    bench.replay(f"""
        > 18EEFF21 00 00 00 00 00 00 00 00
        < 18EEFFFE {NAME}                    # cannot claim
        press 1
        < -
        > 18EF2100 04 1B 2A FF FF FF FF FF
        < -
    """)
    assert snapshot(bench)["j1939"]["address_claim"] == "cannot claim"


def test_with_claim_off_the_keypad_ignores_claims(bench: Bench) -> None:
    bench.replay("""
        > 18EEFF21 00 00 00 00 00 00 00 00
        < -
        > 18EAFF00 00 EE 00
        < -
        press 1
        < 18EFFF21 04 1B 01 01 01 21 FF FF
    """)


# -- J-2: what the keypad ignores ----------------------------------------------------------------


@pytest.mark.parametrize("text", [
    "18EF2200 04 1B 2A FF FF FF FF FF",  # another keypad's address
    "18EE2100 04 1B 2A FF FF FF FF FF",  # another PGN
    "18EF2100 04 1C 2A FF FF FF FF FF",  # wrong header
    "18EF2100 04 1B 2A FF FF FF FF",  # not 8 bytes
    "18EF2100 04 1B 99 FF FF FF FF FF",  # no such command
    "18EF2100 04 1B 01 0D 01 01 00 FF",  # key 13
    "18EF2100 04 1B 02 40 FF FF FF FF",  # level over 3Fh
    "18EF2100 04 1B 80 01 FF FF FF FF",  # the switch needs 00h
    "6F5 04 1B 2A FF FF FF FF FF",  # a standard frame
])
def test_j2_ignored_frames(bench: Bench, text: str) -> None:
    before = snapshot(bench)
    assert bench.twin.receive(frame(text), bench.now) == []
    assert snapshot(bench) == before


def test_j2_global_address_is_accepted(bench: Bench) -> None:
    bench.replay("""
        > 0CEFFF05 04 1B 2A FF FF FF FF FF    # any priority and sender, DA FFh
        < 18EFFF21 04 1B 2A 56 32 2E 36 00
    """)


@settings(max_examples=300, deadline=None)
@given(st.integers(0, 0x1FFFFFFF), st.binary(max_size=8))
def test_random_extended_frames_never_raise(can_id: int, data: bytes) -> None:
    twin = KeypadTwin(protocol="j1939")
    twin.power_on(0.0)
    for reply in twin.receive(Frame(can_id, data, extended=True), 0.1):
        assert reply.extended
    twin.advance(1.0)
    assert twin.snapshot()["protocol"] in ("j1939", "canopen")


# -- J-1: switching, stored protocol --------------------------------------------------------------


def test_j1_switch_from_canopen_and_back(manual: str) -> None:
    bench = Bench(KeypadTwin(manual=manual))
    bench.replay("""
        on
        < 715 00
        > 615 2B FF 20 01 01
        < 595 60 FF 20 01 00 00 00 00
    """)
    assert snapshot(bench)["protocol"] == "j1939"
    assert (snapshot(bench)["bitrate"], snapshot(bench)["j1939"]["source_address"]) == (
        250_000, 0x21)  # J-1: the J1939 defaults
    bench.replay("""
        wait 10
        press 2
        < 18EFFF21 04 1B 01 02 01 21 FF FF
        > 18EF2100 04 1B 70 23 FF FF FF FF    # a J1939 setting, stored
        off
        on
        < -                                   # still J1939 after a power cycle
        > 18EF2300 04 1B 80 00 FF FF FF FF    # §27, to its current address
        < 715 00
    """)
    assert snapshot(bench)["protocol"] == "canopen"
    bench.replay("""
        off
        on
        < 715 00
        > 615 2B FF 20 01 01
        < 595 60 FF 20 01 00 00 00 00
        wait 10
        press 1
        < 18EFFF23 04 1B 01 01 01 21 FF FF    # J-1: stored J1939 settings kept
    """)


def test_the_protocol_argument_is_the_factory_protocol(tmp_path: Path) -> None:
    path = tmp_path / "keypad.json"
    twin = KeypadTwin(nvm=path, protocol="j1939")
    twin.power_on(0.0)
    assert twin.snapshot()["protocol"] == "j1939"
    assert twin.receive(frame("18EF2100 04 1B 70 30 FF FF FF FF"), 1.0) == []
    twin.receive(frame("18EF3000 04 1B 80 00 FF FF FF FF"), 1.0)
    assert twin.snapshot()["protocol"] == "canopen"
    twin.close()
    again = KeypadTwin(nvm=path, protocol="j1939")  # a stored protocol wins
    again.power_on(0.0)
    assert again.snapshot()["protocol"] == "canopen"
    stored = json.loads(path.read_text())["settings"]
    assert stored["j1939_source_address"] == 0x30
    again.close()
    with pytest.raises(ValueError, match="protocol must be one of canopen, j1939"):
        KeypadTwin(protocol="nmea")


def test_an_nvm_file_with_an_invalid_j1939_value_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "keypad.json"
    twin = KeypadTwin(nvm=path, protocol="j1939")
    twin.power_on(0.0)
    twin.close()
    document = json.loads(path.read_text())
    document["settings"]["j1939_source_address"] = 0xFE
    path.write_text(json.dumps(document))
    with pytest.raises(NvmError, match="j1939_source_address"):
        KeypadTwin(nvm=path)


def test_the_j1939_keypad_snapshot_is_json(bench: Bench) -> None:
    text = json.dumps(snapshot(bench))
    assert json.loads(text)["j1939"] == {
        "source_address": 0x21, "identifier": 0x21, "destination_address": 0xFF,
        "address_claim": "off", "name": NAME, "heartbeat_ms": 0, "periodic_key_state_ms": 0,
        "event_key_state": True, "led_acknowledge": False, "led_management": "single"}


def test_two_keypads_do_not_take_each_others_messages_for_commands() -> None:
    """J-2 accepts commands to FFh; the FFh padding (§4) keeps messages from being commands."""
    first, second = KeypadTwin(protocol="j1939"), KeypadTwin(protocol="j1939")
    for twin in (first, second):
        twin.power_on(0.0)
        twin.advance(10.0)
    second.receive(frame("18EF2100 04 1B 70 22 01 FF FF FF"), 10.0)
    revision = first.receive(frame("18EFFF00 04 1B 2A FF FF FF FF FF"), 10.0)
    assert second.receive(revision[0], 10.0) == []  # a reply is no request
    key = first.press(5, 10.0)[0]  # 04 1B 01 05 01 21 FF FF
    assert second.receive(key, 10.0) == []
    assert second.snapshot()["keys"][4]["colour"] == "off"
    identifier_01 = KeypadTwin(protocol="j1939")
    identifier_01.power_on(0.0)
    identifier_01.receive(frame("18EF2100 04 1B 70 23 01 FF FF FF"), 0.0)
    second.receive(identifier_01.press(5, 10.0)[0], 10.0)  # 01 05 01 01 FF: state on
    assert second.snapshot()["keys"][4]["colour"] == "off"


_STORED = [c for c in COMMANDS if c.persistence is Persistence.STORED]


@st.composite
def stored_commands(draw: st.DrawFn) -> bytes:
    command = draw(st.sampled_from(_STORED))
    values = [draw(st.sampled_from([v for lo, hi in f.valid.spans for v in range(lo, hi + 1)]))
              for f in command.fields]
    return command.encode(*values)


@settings(max_examples=60, deadline=None)
@given(st.lists(stored_commands(), max_size=8))
def test_j1939_settings_survive_power_cycles(commands: list[bytes]) -> None:
    twin = KeypadTwin(protocol="j1939")
    twin.power_on(0.0)
    for data in commands:
        twin.receive(Frame(0x18EF0000 | twin.j1939.address << 8, data, extended=True), 1.0)
    stored = dict(twin.j1939.settings)
    twin.power_off()
    twin.power_on(2.0)
    assert twin.j1939.settings == stored
    assert twin.snapshot()["j1939"]["source_address"] == stored["source_address"]
    assert twin.snapshot()["bitrate"] == BITRATES[stored["baud_rate"]]


def test_the_pkp3500_in_j1939_mode_is_silent_and_only_comes_back() -> None:
    """MT M82: its J1939 behaviour is outside its manual; errata "Protocol switch"."""
    bench = Bench(KeypadTwin(model="pkp-3500-mt"))
    bench.replay("""
        on
        < 715 00
        > 615 2B FF 20 01 01
        < 595 60 FF 20 01 00 00 00 00
        wait 10
        press 1
        < -
        > 18EF2100 04 1B 2A FF FF FF FF FF
        < -
        > 18EF2100 04 1B 80 00 FF FF FF FF
        < 715 00
    """)
    assert len(snapshot(bench)["keys"]) == 15
    with pytest.raises(ValueError, match="no documented J1939 mode"):
        KeypadTwin(model="pkp-3500-mt", protocol="j1939")
