"""Command line: the demo, and clear one-line errors for a user's mistakes."""

from __future__ import annotations

from pathlib import Path

import pytest
from click.testing import CliRunner

from blinkcan.cli.main import cli


def test_demo_shows_the_manual_frames_and_their_meaning() -> None:
    result = CliRunner().invoke(cli, ["demo"], env={"COLUMNS": "160"})
    assert result.exit_code == 0, result.output
    for text in ("715", "boot-up", "43 00 10 00 91 01 0B 00", "'BlinkMa'", "keys pressed: 4",
                 "LEDs on: red 2, 7; green 5", "object does not exist", "backlight blue at 32/63",
                 "NMT stopped", "70C", "'Keybox3'", "outputs OFF: none; HIGH: 1, 4",
                 "pins in FAULT: 4", "4:OFF", "1:OFF"):
        assert text in result.output, text


@pytest.mark.parametrize(("args", "message"), [
    (["emulate", "toaster"], "unknown device 'toaster'"),
    (["emulate", "keypad:0x80"], "node id 0x80 outside"),
    (["emulate", "keypad", "--node-id", "zz"], "is not a number"),
    (["emulate", "keypad", "keypad:0x16", "--nvm", "x.json"], "--nvm names one file"),
    (["emulate", "keypad", "-i", "no-such-interface"], "cannot open the bus"),
])
def test_emulate_mistakes_are_one_clear_line(args: list[str], message: str) -> None:
    result = CliRunner().invoke(cli, args)
    assert result.exit_code != 0
    assert message in result.output
    assert "Traceback" not in result.output


def test_emulate_refuses_a_corrupt_nvm_file(tmp_path: Path) -> None:
    path = tmp_path / "nvm.json"
    path.write_text("garbage")
    result = CliRunner().invoke(cli, ["emulate", "keypad", "--nvm", str(path)])
    assert result.exit_code == 1
    assert "not valid JSON" in result.output
    assert path.read_text() == "garbage"


def test_emulate_builds_several_devices_on_one_bus() -> None:
    from blinkcan.cli.emulate import build_twins

    twins = build_twins(("keypad", "keybox:0x0D", "keypad:16h"), None, None, "cia301", (2,))
    assert [(t.description.kind, t.node_id) for t in twins] == [
        ("keypad", 0x15), ("keybox", 0x0D), ("keypad", 0x16)]
    assert twins[1].snapshot()["pins"][1]["low_side"] is True


def test_emulate_refuses_a_low_side_pin_the_keybox_cannot_have() -> None:
    result = CliRunner().invoke(cli, ["emulate", "keybox", "--low-side", "3"])
    assert result.exit_code != 0
    assert "only pins (2, 5)" in result.output
