"""``decode --help`` and ``monitor --help`` name every device the decoder assumes without
--device, read from the decoder itself: decode's help left out the J1939 keypad at 21h, and
monitor's named no default, no encoder, input or J1939 (session 7)."""

from __future__ import annotations

import pytest
from click.testing import CliRunner

from blinkcan.cli.decode import assumed_text, parse_devices
from blinkcan.cli.main import cli
from blinkcan.decode import Decoder

COMMANDS = ["decode", "monitor"]


def _description(command: str) -> str:
    """The command's own help paragraph (before its options), on one line."""
    result = CliRunner().invoke(cli, [command, "--help"], env={"COLUMNS": "100"})
    assert result.exit_code == 0, result.output
    return " ".join(result.output.partition("Options:")[0].split())


def _assumed() -> list[str]:
    """What a decoder built without --device assumes: each node as "kind NNh", each J1939
    address as "J1939 ... at NNh"."""
    decoder = Decoder(parse_devices(()))
    assert decoder.devices
    assert decoder.j1939.addresses
    return [*(f"{d.kind} {node:02X}h" for node, d in decoder.devices.items()),
            *(f"at {address:02X}h" for address in decoder.j1939.addresses)]


@pytest.mark.parametrize("command", COMMANDS)
def test_the_help_names_every_device_assumed(command: str) -> None:
    text = _description(command)
    for device in _assumed():
        assert device in text, (device, text)
    assert "J1939" in text
    assert "{" not in text  # no placeholder left


def test_the_stderr_note_names_the_same_devices() -> None:
    note = assumed_text()
    for device in _assumed():
        assert device in note


def test_monitor_help_names_what_it_shows() -> None:
    text = _description("monitor")
    for shown in ("encoders", "inputs", "J1939"):
        assert shown in text
