"""``monitor --file LOG`` reads a log and opens no bus: a bus option given with it (before or
after the command) is refused in one line, exit 2, before the log is read, as the commands that
open no bus refuse them (cli/main.py). It was taken and ignored in silence: a user who typed
``monitor --file run.log -i socketcan`` could believe they watched the bus."""

from __future__ import annotations

from pathlib import Path

import pytest
from click.testing import CliRunner

from blinkcan.cli.main import cli

#: every bus option, as a command line spells it, with a value
BUS_OPTIONS = {"--interface": ["-i", "virtual"], "--channel": ["-c", "can0"],
               "--bitrate": ["-b", "250000"], "--bus-kwargs": ["--bus-kwargs", "port=1"]}


@pytest.mark.parametrize("where", ["before", "after"])
@pytest.mark.parametrize("option", sorted(BUS_OPTIONS))
def test_monitor_file_refuses_a_bus_option_in_one_line(tmp_path: Path, option: str,
                                                       where: str) -> None:
    log = tmp_path / "run.log"
    log.write_text("(1.000000) can0 70C#05\n")
    monitor = ["monitor", "--file", str(log), "--speed", "0"]
    given = BUS_OPTIONS[option]
    args = [*given, *monitor] if where == "before" else [*monitor, *given]
    result = CliRunner().invoke(cli, args)
    assert result.exit_code == 2, result.output
    lines = result.output.splitlines()
    assert len(lines) == 1, result.output
    assert lines[0].startswith(f"Error: blinkcan monitor --file reads a log and opens no bus: "
                               f"{option} does not apply"), result.output


def test_monitor_file_names_every_bus_option_given(tmp_path: Path) -> None:
    log = tmp_path / "run.log"
    log.write_text("(1.000000) can0 70C#05\n")
    result = CliRunner().invoke(cli, ["-i", "virtual", "monitor", "--file", str(log),
                                      "-c", "can0"])
    assert result.exit_code == 2, result.output
    assert "--interface, --channel do not apply" in result.output, result.output


def test_monitor_file_without_bus_options_still_replays(tmp_path: Path) -> None:
    log = tmp_path / "run.log"
    log.write_text("(1.000000) can0 70C#05\n")
    result = CliRunner().invoke(cli, ["monitor", "--file", str(log), "--speed", "0"])
    assert result.exit_code == 0, result.output
    assert "keybox 0Ch" in result.output, result.output
