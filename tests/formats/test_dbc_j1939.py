"""The J1939 DBC of the keypad (cantools): every spec example frame decodes to its meaning."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import cantools
import pytest
from click.testing import CliRunner

from blinkcan.cli.main import cli
from blinkcan.formats.dbc_j1939 import dbc_text
from tests.conftest import frame


@pytest.fixture(scope="module")
def db() -> Any:
    return cantools.database.load_string(dbc_text(), "dbc")


#: every example frame of spec/pkp-2600-si-j1939.md, with the meaning the spec gives it
SPEC_FRAMES = [
    # messages from the keypad, all on 18EFFF21h (§6, §18, §19, §11)
    ("18EFFF21 04 1B 01 01 01 21 FF FF",
     {"frame": "message", "command": "key", "key_number": 1, "key_state": "pressed",
      "key_identifier": 0x21}),
    ("18EFFF21 04 1B 01 01 00 21 FF FF", {"key_number": 1, "key_state": "released"}),
    ("18EFFF21 04 1B 01 0C 01 21 FF FF", {"key_number": 12, "key_state": "pressed"}),
    ("18EFFF21 04 1B F9 03 80 00 FF 21",
     {"command": "heartbeat", "heartbeat_counter": 3, "heartbeat_key_8": 1,
      "heartbeat_key_12": 0, "heartbeat_identifier": 0x21}),
    ("18EFFF21 04 1B F9 03 00 08 FF 21", {"heartbeat_key_8": 0, "heartbeat_key_12": 1}),
    ("18EFFF21 00 03 01 01 02 FF FF FF",  # after 04 1B 01 01 01 03 02 FF (issue 17 item 14)
     {"frame": "led_acknowledge", "led_acknowledge_state": "alternate",
      "led_acknowledge_led": 1, "led_acknowledge_colour": "red",
      "led_acknowledge_secondary": "green"}),
    ("18EFFF21 04 1B 2A 56 32 2E 36 00",  # "V2.6": 4 ASCII bytes as one integer
     {"command": "software_revision", "software_revision": int.from_bytes(b"V2.6", "little")}),
    ("18EEFF21 3F 42 6F 1A 00 82 3C C0", {"name_arbitrary_address_capable": 1}),  # §20
    # commands to the keypad on 18EF2100h (§7a-§27)
    ("18EF2100 04 1B 01 01 01 01 00 FF",
     {"command": "single_led", "single_led_key": 1, "single_led_colour": "red",
      "single_led_state": "on", "single_led_secondary": "off"}),
    ("18EF2100 04 1B 01 01 00 00 00 FF",
     {"single_led_key": 1, "single_led_colour": "off", "single_led_state": "off"}),
    ("18EF2100 04 1B 01 02 03 02 00 FF",
     {"single_led_key": 2, "single_led_colour": "blue", "single_led_state": "blink"}),
    ("18EF2100 04 1B 01 06 01 01 00 FF",
     {"single_led_key": 6, "single_led_colour": "red", "single_led_state": "on"}),
    ("18EF2100 04 1B 01 08 02 01 00 FF",
     {"single_led_key": 8, "single_led_colour": "green", "single_led_state": "on"}),
    ("18EF2100 04 1B 01 0B 01 03 02 FF",
     {"single_led_key": 11, "single_led_colour": "red", "single_led_state": "alternate",
      "single_led_secondary": "green"}),
    ("18EF2100 04 1B 01 01 01 03 02 FF",
     {"single_led_key": 1, "single_led_state": "alternate"}),
    ("18EF2100 04 1B 02 20 FF FF FF FF", {"command": "led_brightness", "led_brightness_level": 32}),
    ("18EF2100 04 1B 03 10 FF FF FF FF",
     {"command": "backlight_level", "backlight_level_level": 0x10}),
    ("18EF2100 04 1B 28 01 FF FF FF FF", {"key_message_at_startup_on": 1}),
    ("18EF2100 04 1B 2A FF FF FF FF FF", {"command": "software_revision"}),
    ("18EF2100 04 1B 34 02 FF FF FF FF", {"startup_led_show_show": 2}),
    ("18EF2100 04 1B 37 02 FF FF FF FF", {"led_management_mode": 2}),
    ("18EF2100 04 1B 6E 00 FF FF FF FF", {"destination_address_address": 0}),
    ("18EF2100 04 1B 6F 02 FF FF FF FF", {"baud_rate_code": 2}),
    ("18EF2100 04 1B 70 02 01 FF FF FF",
     {"source_address_address": 2, "source_address_identifier": 1}),
    ("18EF2100 04 1B 71 01 FF FF FF FF", {"periodic_key_state_on": 1}),
    ("18EF2100 04 1B 72 00 FF FF FF FF", {"event_key_state_on": 0}),
    ("18EF2100 04 1B 73 01 FF FF FF FF", {"led_acknowledge_on": 1}),
    ("18EF2100 04 1B 74 01 FF FF FF FF", {"address_claim_on": 1}),
    ("18EF2100 04 1B 75 01 32 FF FF FF",
     {"command": "heartbeat", "heartbeat_on": 1, "heartbeat_period": 0x32}),
    ("18EF2100 04 1B 77 0A FF FF FF FF", {"key_message_period_period": 0x0A}),
    ("18EF2100 04 1B 7A 01 FF FF FF FF", {"demo_mode_on": 1}),
    ("18EF2100 04 1B 7B 20 FF FF FF FF", {"startup_backlight_level_level": 0x20}),
    ("18EF2100 04 1B 7C 10 FF FF FF FF", {"startup_led_brightness_level": 0x10}),
    ("18EF2100 04 1B 7D 02 FF FF FF FF", {"backlight_colour_colour": "green"}),
    ("18EF2100 04 1B 80 00 FF FF FF FF", {"command": "switch_to_canopen"}),
    # multiple-LED frames (§7b)
    ("18A72100 11 01 00 00 00 00 FF FF", {"led_1": "red", "led_3": "red", "led_4": "off"}),
    ("18A62100 00 00 00 00 00 96 FF FF", {"led_11": "magenta", "led_12": "yellow/green"}),
    ("18A72100 22 22 22 22 22 22 FF FF", {f"led_{key}": "green" for key in range(1, 13)}),
]


@pytest.mark.parametrize(("text", "signals"), SPEC_FRAMES)
def test_spec_frames_decode_with_the_dbc(db: Any, text: str, signals: dict[str, Any]) -> None:
    example = frame(text)
    decoded = db.decode_message(example.can_id, example.data)
    assert {name: decoded.get(name) for name in signals} == signals


def test_the_led_acknowledge_is_no_key_message(db: Any) -> None:
    """``00 03 01 01 02 FF FF FF`` decoded as "key 1" in cantools (issue 17 item 14): byte 0
    tells the two apart, and neither carries the other's signals."""
    acknowledge = db.decode_message(0x18EFFF21, bytes.fromhex("0003010102FFFFFF"))
    key = db.decode_message(0x18EFFF21, bytes.fromhex("041B01010121FFFF"))
    assert not any(name.startswith("key") or name == "command" for name in acknowledge)
    assert not any(name.startswith("led_acknowledge") for name in key)


def test_it_is_a_j1939_dbc(db: Any) -> None:
    text = dbc_text(address=0x30)
    assert 'BA_ "ProtocolType" "J1939";' in text
    assert all(message.protocol == "j1939" for message in db.messages)
    other: Any = cantools.database.load_string(text, "dbc")
    assert {m.frame_id for m in other.messages} == {
        0x18EF3000, 0x18EFFF30, 0x18A73000, 0x18A63000, 0x18EEFF30}
    decoded = db.decode_message(0x18EF2100, bytes.fromhex("041B0220FFFFFFFF"))
    assert (decoded["header"], decoded["command"]) == (0x1B04, "led_brightness")


def test_export_writes_it(tmp_path: Path) -> None:
    path = tmp_path / "keypad-j1939.dbc"
    result = CliRunner().invoke(cli, ["export", "dbc", "keypad", "--protocol", "j1939",
                                      "--address", "0x22", "-o", str(path)])
    assert result.exit_code == 0, result.output
    assert "KEYPAD_22_COMMAND" in path.read_text()
    refused = CliRunner().invoke(cli, ["export", "eds", "keypad", "--protocol", "j1939"])
    assert refused.exit_code == 2
    assert "J1939 mode" in refused.output
