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


@pytest.mark.parametrize(("text", "signals"), [
    ("18EFFF21 04 1B 01 01 01 21 FF FF",
     {"command": "key", "key_number": 1, "key_state": "pressed", "key_identifier": 0x21}),
    ("18EFFF21 04 1B 01 0C 00 21 FF FF", {"key_number": 12, "key_state": "released"}),
    ("18EFFF21 04 1B F9 03 80 00 FF 21",
     {"command": "heartbeat", "heartbeat_counter": 3, "heartbeat_key_8": 1,
      "heartbeat_key_12": 0}),
    ("18EFFF21 04 1B F9 03 00 08 FF 21", {"heartbeat_key_8": 0, "heartbeat_key_12": 1}),
    ("18EF2100 04 1B 01 0B 01 03 02 FF",
     {"command": "single_led", "single_led_key": 11, "single_led_colour": "red",
      "single_led_state": "alternate", "single_led_secondary": "green"}),
    ("18EF2100 04 1B 01 02 03 02 00 FF",
     {"single_led_key": 2, "single_led_colour": "blue", "single_led_state": "blink"}),
    ("18EF2100 04 1B 02 20 FF FF FF FF", {"command": "led_brightness", "led_brightness_level": 32}),
    ("18EF2100 04 1B 75 01 32 FF FF FF",
     {"command": "heartbeat", "heartbeat_on": 1, "heartbeat_period": 0x32}),
    ("18EF2100 04 1B 70 02 01 FF FF FF",
     {"source_address_address": 2, "source_address_identifier": 1}),
    ("18EF2100 04 1B 7D 02 FF FF FF FF", {"backlight_colour_colour": "green"}),
    ("18EF2100 04 1B 80 00 FF FF FF FF", {"command": "switch_to_canopen"}),
    ("18A72100 11 01 00 00 00 00 FF FF", {"led_1": "red", "led_3": "red", "led_4": "off"}),
    ("18A62100 00 00 00 00 00 96 FF FF", {"led_11": "magenta", "led_12": "yellow/green"}),
    ("18EEFF21 3F 42 6F 1A 00 82 3C C0", {"name_arbitrary_address_capable": 1}),
])
def test_spec_frames_decode_with_the_dbc(db: Any, text: str, signals: dict[str, Any]) -> None:
    example = frame(text)
    decoded = db.decode_message(example.can_id, example.data)
    assert {name: decoded[name] for name in signals} == signals


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
