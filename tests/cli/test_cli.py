"""Command line: the demo, and clear one-line errors for a user's mistakes."""

from __future__ import annotations

from pathlib import Path

import pytest
from click.testing import CliRunner

from blinkcan.cli.main import cli


def test_demo_runs_the_controller_and_shows_outputs_and_frames() -> None:
    result = CliRunner().invoke(cli, ["demo", "--pause", "0"],  # as a terminal shows it
                                env={"COLUMNS": "160", "TTY_COMPATIBLE": "1", "NO_COLOR": "1"})
    assert result.exit_code == 0, result.output
    for text in ("firmware V2.2", "Keybox Keybox3", "4:HIGH", "1:OFF", "7:HIGH", "operational",
                 "outputs HIGH at the end: [4, 7]", "keypad 15h: LEDs on"):
        assert text in result.output, text


@pytest.mark.parametrize(("args", "message"), [
    (["emulate", "toaster"], "unknown device 'toaster'"),
    (["emulate", "keypad:0x80"], "node id 0x80 outside"),
    (["emulate", "keypad", "--node-id", "zz"], "is not a node id: 01h..7Fh"),
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
