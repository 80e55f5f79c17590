"""A number of seconds on the command line is finite (DESIGN: non-finite times are bad
arguments): ``nan`` or ``inf`` is a usage error before the bus opens, never a scan that
crashes, an NMT listen "within nan s" or a recording of 0 frames (found by the
newcomer/attacker pass of session 4)."""

from __future__ import annotations

from pathlib import Path

import pytest
from click.testing import CliRunner

from blinkcan.cli.main import cli

# an interface python-can does not know: reaching the bus would be another error
NO_BUS = ["-i", "no-such-interface"]


@pytest.mark.parametrize("value", ["nan", "inf", "-inf", "NaN", "1e400"])
@pytest.mark.parametrize("command", [["scan", "--listen"], ["nmt", "start", "all", "--listen"],
                                     ["record", "OUT", "--duration"]])
def test_a_non_finite_number_of_seconds_is_a_usage_error(tmp_path: Path, command: list[str],
                                                         value: str) -> None:
    out = tmp_path / "out.log"
    line = [str(out) if word == "OUT" else word for word in command] + [value, *NO_BUS]
    result = CliRunner().invoke(cli, line)
    assert result.exit_code == 2, result.output
    [error] = result.output.splitlines()
    assert "finite number of seconds" in error, error
    assert not out.exists()  # refused before anything was written


@pytest.mark.parametrize("value", ["nan", "inf", "1e400"])
@pytest.mark.parametrize(("option", "unit"), [("--speed", "times the pace"),
                                              ("--duration", "seconds")])
def test_monitor_refuses_a_non_finite_speed_or_duration(tmp_path: Path, option: str, unit: str,
                                                        value: str) -> None:
    log = tmp_path / "bus.log"
    log.write_text("(1.000000) vcan0 18A#0000000001\n")
    result = CliRunner().invoke(cli, ["monitor", "--file", str(log), option, value])
    assert result.exit_code == 2, result.output
    assert f"finite number of {unit}" in result.output.splitlines()[-1]


@pytest.mark.parametrize("value", ["nan", "inf", "-1"])
def test_demo_refuses_a_pause_that_is_not_seconds(value: str) -> None:
    # `demo --pause nan` ran the demo until its first pause: "unexpected ValueError: Invalid
    # value NaN" (found by the attack pass of session 5)
    result = CliRunner().invoke(cli, ["demo", "--pause", value])
    assert result.exit_code == 2, result.output
    [error] = result.output.splitlines()
    assert "--pause" in error
