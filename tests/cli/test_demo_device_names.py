"""An unknown device name is answered, wherever a device name is parsed (``demo --model``,
``emulate``, ``export``, ``decode`` and ``monitor --device``, the Python API), with every way
to spell a registered one: DEVICE[@GEN][/PROTOCOL], each model with its aliases, its
generations and the protocols it speaks besides CANopen. The message named neither the
/PROTOCOL part (emulate's ``keypad/j1939``) nor which model has which protocol."""

from __future__ import annotations

from pathlib import Path

import pytest
from click.testing import CliRunner

from blinkcan.cli.main import cli
from blinkcan.devices.registry import describe_device, models

#: the protocols a model may speak besides CANopen (its description's features name them)
OTHER_PROTOCOLS = ("j1939",)


def _expected_parts() -> list[str]:
    """What the message must name: the form, and each model with its spellings."""
    parts = ["DEVICE[@GEN][/PROTOCOL]"]
    for found in models():
        parts.append(found.name)
        parts.extend(found.aliases)
        if len(found.generations) > 1:
            parts.extend(f"{found.name}@{generation}" for generation in found.generations)
        spoken = {protocol for generation in found.generations for protocol in OTHER_PROTOCOLS
                  if protocol in found.description(generation).features}
        parts.extend(f"{found.name}/{protocol}" for protocol in sorted(spoken))
    return parts


def _check(message: str) -> None:
    for part in _expected_parts():
        assert part in message, (part, message)
    assert message.count("/j1939") == 1, message  # the one model that has it


@pytest.mark.parametrize("args", [
    ["demo", "--model", "toaster", "--pause", "0"],
    ["emulate", "toaster"],
    ["emulate", "toaster/j1939"],
    ["export", "dbc", "toaster"],
    ["decode", "{log}", "--device", "0x15=toaster"],
    ["monitor", "--file", "{log}", "--device", "0x15=toaster"],
], ids=lambda args: " ".join(args[:2]))
def test_an_unknown_device_is_answered_with_every_spelling(tmp_path: Path,
                                                           args: list[str]) -> None:
    log = tmp_path / "x.log"
    log.write_text("(1.000000) can0 70C#05\n")
    result = CliRunner().invoke(cli, [arg.format(log=log) for arg in args])
    assert result.exit_code == 2, result.output
    assert len(result.output.splitlines()) == 1, result.output
    assert "unknown device 'toaster'" in result.output
    _check(result.output)


def test_the_python_api_names_every_spelling_too() -> None:
    with pytest.raises(ValueError, match="unknown device 'toaster'") as raised:
        describe_device("toaster")
    _check(str(raised.value))
