"""Keypad rules the manual states in words (and errata.md decisions), beyond its examples."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from blinkcan.twin import KeypadTwin, NvmError
from tests.conftest import frame
from tests.twin.trace import Bench


@pytest.fixture
def bench() -> Bench:
    bench = Bench(KeypadTwin())
    bench.replay("on\n< 715 00\nwait 10")
    return bench


# -- SDO abort codes (issue 2, CiA 301) --------------------------------------------------------

@pytest.mark.parametrize(("request_", "reply"), [
    ("40 34 12 00 00 00 00 00", "80 34 12 00 00 00 02 06"),  # unknown object
    ("40 00 10 01 00 00 00 00", "80 00 10 01 11 00 09 06"),  # unknown sub-index
    ("40 00 18 03 00 00 00 00", "80 00 18 03 11 00 09 06"),  # 1800h has no sub 03h (P18)
    ("23 00 10 00 00 00 00 00", "80 00 10 00 02 00 01 06"),  # read-only
    ("2F 17 10 00 05 00 00 00", "80 17 10 00 10 00 07 06"),  # wrong length
    ("2B 17 10 00 05 00 00 00", "80 17 10 00 30 00 09 06"),  # 1..9 ms (P1)
    ("2B 17 10 00 00 FF 00 00", "80 17 10 00 30 00 09 06"),  # 65280 ms (P1)
    ("2F 13 20 00 00 00 00 00", "80 13 20 00 30 00 09 06"),  # node id 0 (P11)
    ("2F 13 20 00 80 00 00 00", "80 13 20 00 30 00 09 06"),  # node id 80h (P11)
    ("2F 10 20 00 08 00 00 00", "80 10 20 00 30 00 09 06"),  # baud code 8 (B1)
    ("2F 03 20 01 40 00 00 00", "80 03 20 01 30 00 09 06"),  # level > 3Fh (P15)
    ("2F 03 20 03 00 00 00 00", "80 03 20 03 30 00 09 06"),  # colour 00h
    ("2F 03 20 04 0A 00 00 00", "80 03 20 04 30 00 09 06"),  # colour 0Ah
    ("2B 01 20 01 00 10 00 00", "80 01 20 01 30 00 09 06"),  # LED bit 13
    ("2B FF 20 01 02 00 00 00", "80 FF 20 01 30 00 09 06"),  # protocol 2
    ("A0 00 10 00 00 00 00 00", "80 00 10 00 01 00 04 05"),  # block upload: bad specifier
    ("E0 00 10 00 00 00 00 00", "80 00 10 00 01 00 04 05"),  # ccs 7
    ("60 00 00 00 00 00 00 00", "80 00 00 00 01 00 04 05"),  # segment, no transfer
])
def test_sdo_abort_codes(bench: Bench, request_: str, reply: str) -> None:
    bench.replay(f"> 615 {request_}\n< 595 {reply}")


def test_toggle_error_aborts_the_upload(bench: Bench) -> None:
    bench.replay("""
        > 615 40 08 10 00 00 00 00 00
        < 595 41 08 10 00 0B 00 00 00
        > 615 70 00 00 00 00 00 00 00
        < 595 80 08 10 00 00 00 03 05
    """)


def test_a_rejected_write_changes_nothing(bench: Bench) -> None:
    bench.replay("> 615 2B 17 10 00 05 00 00 00\n< 595 80 17 10 00 30 00 09 06")
    assert bench.twin.objects["producer_heartbeat_time"] == 0


# -- NMT gating (CiA 301 table 84) -------------------------------------------------------------

def test_no_sdo_and_no_pdo_while_stopped(bench: Bench) -> None:
    bench.replay("""
        > 000 01 15
        > 000 02 15
        > 615 40 00 10 00 00 00 00 00
        < -
        > 215 01 00 00 00 00 00 00 00
        press 1
        < -
    """)
    assert bench.twin.objects["led_on_red"] == 0


def test_pdos_act_only_while_operational(bench: Bench) -> None:
    bench.replay("> 215 01 00 00 00 00 00 00 00\npress 1\n< -")
    assert bench.twin.objects["led_on_red"] == 0
    bench.replay("release 1\n> 000 01 15\n> 215 01 00 00 00 00 00 00 00\n"
                 "press 1\n< 195 01 00 00 00 ??")
    assert bench.twin.objects["led_on_red"] == 1


def test_heartbeat_goes_on_while_stopped_with_state_04(bench: Bench) -> None:
    bench.replay("""
        > 615 2B 17 10 00 64 00 00 00
        < 595 60 17 10 00 00 00 00 00
        > 000 02 00                      # broadcast stop
        wait 0.1
        < 715 04
    """)


def test_nmt_for_another_node_is_ignored(bench: Bench) -> None:
    bench.replay("> 000 01 16")
    assert bench.twin.snapshot()["nmt_state"] == "pre-operational"


def test_nmt_trailing_bytes_accepted_short_frames_ignored(bench: Bench) -> None:
    bench.replay("> 000 01\n> 000 01 15 00 00 00 00 00 00")  # errata B4
    assert bench.twin.snapshot()["nmt_state"] == "operational"


def test_brightness_pdo_dlc_1_accepted_out_of_range_ignored(bench: Bench) -> None:
    bench.replay("> 000 01 15\n> 415 10\n> 415 40 00 00 00 00 00 00 00")
    assert bench.twin.objects["indicator_brightness"] == 0x10  # errata P14/P15


def test_led_pdo_shorter_than_five_bytes_is_ignored(bench: Bench) -> None:
    bench.replay("> 000 01 15\n> 215 01 00 00 00")
    assert bench.twin.objects["led_on_red"] == 0


# -- resets and settings (errata "When settings take effect") ------------------------------------

def test_node_id_applies_at_the_next_reset_and_ack_comes_from_the_old_id(bench: Bench) -> None:
    bench.replay("""
        > 615 2F 13 20 00 18 00 00 00
        < 595 60 13 20 00 00 00 00 00
        > 615 40 13 20 00 00 00 00 00    # reads the stored value already
        < 595 4F 13 20 00 18 00 00 00
        > 000 81 15
        < 718 00
        > 615 40 00 10 00 00 00 00 00
        < -
        > 618 40 00 10 00 00 00 00 00
        < 598 43 00 10 00 91 01 0B 00
    """)


def test_baud_rate_applies_at_the_next_reset(bench: Bench) -> None:
    bench.replay("> 615 2F 10 20 00 03 00 00 00\n< 595 60 10 20 00 00 00 00 00")
    assert bench.twin.snapshot()["bitrate"] == 125_000
    bench.replay("> 000 81 15\n< 715 00")
    assert bench.twin.snapshot()["bitrate"] == 250_000


def test_reset_communication_keeps_the_leds_reset_node_clears_them(bench: Bench) -> None:
    bench.replay("> 000 01 15\n> 215 01 00 00 00 00 00 00 00\n> 000 82 15\n< 715 00")
    assert bench.twin.objects["led_on_red"] == 1
    bench.replay("> 000 81 15\n< 715 00")
    assert bench.twin.objects["led_on_red"] == 0


def test_boot_up_off_and_active_on_startup(bench: Bench) -> None:
    bench.replay("""
        > 615 2F 11 20 00 00 00 00 00
        < 595 60 11 20 00 00 00 00 00
        > 615 2F 12 20 00 01 00 00 00
        < 595 60 12 20 00 00 00 00 00
        > 615 2B 17 10 00 64 00 00 00
        < 595 60 17 10 00 00 00 00 00
        off
        on
        < -
        wait 0.1
        < 715 05                         # went operational by itself (§21)
        press 2
        < 195 02 00 00 00 ??
    """)


def test_power_cycle_forgets_leds_keeps_settings(bench: Bench) -> None:
    bench.replay("""
        > 000 01 15
        > 215 FF 0F 00 00 00 00 00 00
        > 615 2F 03 20 04 03 00 00 00
        < 595 60 03 20 04 00 00 00 00
        > 615 2F 03 20 06 20 00 00 00
        < 595 60 03 20 06 00 00 00 00
        off
        > 615 40 00 10 00 00 00 00 00
        < -
        press 1
        < -
        on
        < 715 00
    """)
    snapshot = bench.twin.snapshot()
    assert bench.twin.objects["led_on_red"] == 0
    assert snapshot["backlight"] == {"colour": "blue", "level": 0x20}  # startup values applied
    assert snapshot["settings"]["default_backlight_colour"] == 3


def test_tick_timer_counts_100_ms_and_wraps() -> None:
    twin = KeypadTwin()
    twin.power_on(0.0)
    twin.receive(frame("000 01 15"), 0.0)
    assert twin.press(1, 0.35)[0].data[4] == 3
    assert twin.release(1, 25.65)[0].data[4] == 0  # 256 ticks later: wrapped


def test_powered_off_twin_is_silent() -> None:
    twin = KeypadTwin()
    assert twin.receive(frame("615 40 00 10 00 00 00 00 00"), 0.0) == []
    assert twin.press(1, 0.0) == []
    assert twin.advance(1.0) == []
    assert twin.next_deadline() is None


@pytest.mark.parametrize("bad", [0, 13, -1])
def test_press_rejects_keys_outside_1_to_12(bad: int) -> None:
    with pytest.raises(ValueError, match=r"1\.\.12"):
        KeypadTwin().press(bad, 0.0)


@pytest.mark.parametrize(("kwargs", "message"), [
    ({"node_id": 0}, "node id"), ({"node_id": 0x80}, "node id"), ({"quirks": "strict"}, "quirks"),
    ({"manual": "2.0"}, "manual"),
])
def test_constructor_arguments_are_checked(kwargs: dict[str, object], message: str) -> None:
    with pytest.raises(ValueError, match=message):
        KeypadTwin(**kwargs)  # type: ignore[arg-type]


# -- startup LED show (§23) -----------------------------------------------------------------------

def test_complete_show_plays_then_the_objects_show() -> None:
    twin = KeypadTwin()
    twin.power_on(0.0)
    assert twin.snapshot()["startup_show"] == {"mode": "complete", "step": 0}
    assert twin.snapshot()["keys"][0]["colour"] == "red"
    deadline = twin.next_deadline()
    assert deadline is not None
    assert deadline > 0
    twin.advance(1.0)
    assert twin.snapshot()["keys"][0]["colour"] == "green"
    twin.advance(5.0)
    assert twin.snapshot()["startup_show"] is None
    assert {k["colour"] for k in twin.snapshot()["keys"]} == {"off"}


def test_fast_flash_and_no_show() -> None:
    twin = KeypadTwin()
    twin.power_on(0.0)
    twin.receive(frame("615 2F 14 20 00 02 00 00 00"), 0.0)
    twin.power_off()
    twin.power_on(10.0)
    assert twin.snapshot()["startup_show"]["mode"] == "fast flash"
    assert twin.snapshot()["keys"][5]["colour"] == "white"
    twin.advance(10.15)
    assert twin.snapshot()["keys"][5]["colour"] == "off"
    twin.receive(frame("615 2F 14 20 00 00 00 00 00"), 11.0)
    twin.power_off()
    twin.power_on(20.0)
    assert twin.snapshot()["startup_show"] is None


# -- DEMO mode (§24, appendix, errata P21) ----------------------------------------------

@pytest.fixture
def demo() -> Bench:
    bench = Bench(KeypadTwin())
    bench.replay("""
        on
        < 715 00
        > 615 2F 14 20 00 00 00 00 00
        < 595 60 14 20 00 00 00 00 00
        > 615 2F 00 21 00 01 00 00 00
        < 595 60 00 21 00 00 00 00 00
    """)
    assert bench.twin.snapshot()["demo"] is None  # only after a power cycle
    bench.replay("off\non\n< 715 00")
    return bench


def test_demo_starts_with_a_red_backlight_and_key_1_cycles_colours(demo: Bench) -> None:
    assert demo.twin.snapshot()["backlight"]["colour"] == "red"
    seen = []
    for _ in range(10):
        demo.replay("press 1\nrelease 1")
        seen.append(demo.twin.snapshot()["backlight"]["colour"])
    assert seen == ["green", "blue", "yellow", "cyan", "magenta", "white", "amber",
                    "yellow/green", "off", "red"]  # one name per colour (colours.py)


def test_demo_key_4_steps_and_pairs_blink_alternately(demo: Bench) -> None:
    steps = []
    for _ in range(3):
        demo.replay("press 4\nrelease 4")
        steps.append(demo.twin.snapshot()["demo"]["step"])
    assert steps == ["complete LED show", "keys on in sequence", "alternate blinking pairs"]
    keys = demo.twin.snapshot()["keys"]
    assert keys[0]["phases"] == ["red", "off"]
    assert keys[6]["phases"] == ["off", "red"]
    assert keys[4]["phases"] == ["cyan", "off"]
    assert keys[10]["phases"] == ["off", "cyan"]


def test_demo_keys_2_and_3_change_brightness(demo: Bench) -> None:
    demo.replay("press 3\nrelease 3\npress 3\nrelease 3")
    assert demo.twin.snapshot()["indicator_brightness"] == 0x3F - 16
    demo.replay("press 2\nrelease 2")
    assert demo.twin.snapshot()["indicator_brightness"] == 0x3F - 8


def test_another_command_leaves_demo_mode(demo: Bench) -> None:
    demo.replay("> 000 01 15")
    assert demo.twin.snapshot()["demo"] is None
    assert demo.twin.snapshot()["backlight"] == {"colour": "amber", "level": 0}


# -- non-volatile settings ---------------------------------------------------------------

def test_settings_survive_the_process_in_an_nvm_file(tmp_path: Path) -> None:
    path = tmp_path / "keypad.json"
    first = KeypadTwin(nvm=path)
    first.power_on(0.0)
    first.receive(frame("615 2B 17 10 00 C8 00 00 00"), 0.0)
    first.receive(frame("615 2F 13 20 00 22 00 00 00"), 0.0)
    document = json.loads(path.read_text())
    assert document["model"] == "pkp-2600-si"
    assert document["settings"]["node_id"] == 0x22
    first.close()  # the process ends
    second = KeypadTwin(nvm=path)
    assert second.power_on(0.0) == [frame("722 00")]
    assert second.objects["producer_heartbeat_time"] == 200


def test_a_corrupt_nvm_file_is_refused_and_kept(tmp_path: Path) -> None:
    path = tmp_path / "keypad.json"
    path.write_text("{not json")
    with pytest.raises(NvmError, match="not valid JSON"):
        KeypadTwin(nvm=path)
    assert path.read_text() == "{not json"


def test_a_foreign_nvm_file_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "other.json"
    path.write_text(json.dumps({"format": "blinkcan-nvm", "version": 1, "model": "keybox",
                                "generation": "1.0", "settings": {}}))
    with pytest.raises(NvmError, match="keybox"):
        KeypadTwin(nvm=path)


def test_an_nvm_file_with_an_invalid_value_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "keypad.json"
    KeypadTwin(nvm=path).close()
    document = json.loads(path.read_text())
    document["settings"]["node_id"] = 0
    path.write_text(json.dumps(document))
    with pytest.raises(NvmError, match="node_id"):
        KeypadTwin(nvm=path)


def test_j1939_mode_survives_a_power_cycle_and_the_way_back_restores_defaults() -> None:
    bench = Bench(KeypadTwin())
    bench.replay("""
        on
        < 715 00
        > 615 2B 17 10 00 64 00 00 00
        < 595 60 17 10 00 00 00 00 00
        > 615 2B FF 20 01 01 00 00 00
        < 595 60 FF 20 01 00 00 00 00
        wait 1
        < -                              # no heartbeat in J1939 mode
        off
        on
        < -
        > 18EF21FE 04 1B 80 00 FF FF FF FF   # any source address
        < 715 00
        wait 1
        < -                              # heartbeat back to its default: off
    """)


def test_an_unpowered_twin_has_a_snapshot() -> None:
    snapshot = KeypadTwin(node_id=0x20).snapshot()
    assert (snapshot["nmt_state"], snapshot["node_id"], snapshot["bitrate"]) == ("off", 0x20,
                                                                              125_000)


def test_one_name_for_one_colour_in_the_backlight_and_the_leds() -> None:
    """The backlight's 09h is "yellow/green", as the J1939 LED colour 09h (§7a, §26)."""
    from blinkcan.devices.colours import BacklightColour
    from blinkcan.devices.keypad_j1939 import colour_name
    from blinkcan.protocol import Frame

    for colour in BacklightColour:
        assert colour.label == colour_name(int(colour))
        assert BacklightColour.from_name(colour.label) is colour
    twin = KeypadTwin(protocol="j1939")
    twin.power_on(0.0)
    twin.receive(Frame(0x18EF2100, bytes.fromhex("041B7D09FFFFFFFF"), extended=True), 0.0)
    twin.receive(Frame(0x18EF2100, bytes.fromhex("041B0103090100FF"), extended=True), 0.0)
    snapshot = twin.snapshot()
    assert snapshot["backlight"]["colour"] == "yellow/green"
    assert snapshot["commanded"][2]["colour"] == "yellow/green"
