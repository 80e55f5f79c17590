"""The bus options (-i, -c, -b, --bus-kwargs) go before or after the command (README, Command
line): every command that opens a bus takes them in either order, and gives the same answer;
a command that opens no bus refuses them in either order, one line (``act 15h tap 3 -i
udp_multicast`` sent "-i udp_multicast" to the emulator as command words, and ``blinkcan -i
socketcan demo`` ran the demo on its own bus in silence)."""

from __future__ import annotations

from pathlib import Path

import click
import pytest
from click.testing import CliRunner, Result

from blinkcan.cli.bus_options import takes_bus_options
from blinkcan.cli.main import SUBCOMMANDS, cli, load_subcommand

#: a command line of every command that opens a bus, its arguments valid (they are checked
#: before the bus is opened)
OPENS_A_BUS = {
    "emulate": ["keypad"], "scan": [], "monitor": [], "record": ["{tmp}/new.log"],
    "keypad info": [], "keypad heartbeat": ["100"], "keypad set-node-id": ["0x18"],
    "keypad set-baud": ["250000"], "keypad restore-defaults": [],
    "keypad read": ["producer_heartbeat_time"], "keypad write": ["producer_heartbeat_time",
                                                                 "500"],
    "keypad led": ["3", "red"], "keypad backlight": ["--level", "32"],
    "keypad brightness": ["40"], "keypad ring": ["1", "1,2"], "keypad encoder": ["1"],
    "keypad inputs": [],
    "keybox info": [], "keybox heartbeat": ["100"], "keybox set-node-id": ["0x0D"],
    "keybox set-baud": ["250000"], "keybox restore-defaults": [],
    "keybox read": ["producer_heartbeat_time"], "keybox write": ["producer_heartbeat_time",
                                                                 "500"],
    "keybox on": ["4"], "keybox off": ["4"], "keybox reset": ["4"],
    "keybox pwm": ["12", "5"], "keybox states": [], "keybox faults": [],
    "nmt start": ["0x15"], "nmt stop": ["all"], "nmt pre-operational": ["0x15"],
    "nmt reset": ["0x15"], "nmt reset-communication": ["0x15"],
}
#: every command that opens no bus
OPENS_NO_BUS = {
    "act": ["15h", "tap", "3"], "demo": [], "decode": ["{tmp}/x.log"],
    "convert": ["{tmp}/x.log", "{tmp}/x.pcap"], "export": ["eds", "keypad"],
    "query": ["{tmp}", "SELECT 1"],
}
BUS = ["-i", "nosuchbus", "-c", "x0", "--bus-kwargs", "port=1", "hop_limit=0"]


def _commands() -> dict[str, click.Command]:
    """Every command line's command, by its words ("keypad led")."""
    found: dict[str, click.Command] = {}
    for name in SUBCOMMANDS:
        command = load_subcommand(name)
        if isinstance(command, click.Group):
            found.update({f"{name} {sub}": leaf for sub, leaf in command.commands.items()})
        else:
            found[name] = command
    return found


def test_the_tables_name_every_command() -> None:
    commands = _commands()
    assert {name for name, command in commands.items() if takes_bus_options(command)} == \
        set(OPENS_A_BUS)
    assert set(commands) - set(OPENS_A_BUS) == set(OPENS_NO_BUS)


def _run(tmp_path: Path, args: list[str]) -> Result:
    (tmp_path / "x.log").write_text("(1.000000) can0 70C#05 R\n")
    return CliRunner().invoke(cli, [arg.format(tmp=tmp_path) for arg in args], input="n\n")


@pytest.mark.parametrize("words", sorted(OPENS_A_BUS))
def test_a_command_that_opens_a_bus_takes_its_options_before_or_after(
        tmp_path: Path, words: str) -> None:
    command = words.split()
    arguments = OPENS_A_BUS[words]
    orders = [[*BUS, *command, *arguments], [*command, *arguments, *BUS]]
    if len(command) > 1:  # between the group and its command too
        orders.append([command[0], *BUS, *command[1:], *arguments])
    results = [_run(tmp_path, order) for order in orders]
    for result in results:
        assert result.exit_code == 1, result.output
        assert result.output.endswith('Error: cannot open the bus nosuchbus x0: Unknown '
                                      'interface type "nosuchbus"\n'), result.output
        assert result.output == results[0].output


@pytest.mark.parametrize("words", sorted(OPENS_NO_BUS))
def test_a_command_that_opens_no_bus_refuses_them_before_or_after(
        tmp_path: Path, words: str) -> None:
    arguments = OPENS_NO_BUS[words]
    for order in ([*BUS, words, *arguments], [words, *arguments, *BUS]):
        result = _run(tmp_path, order)
        assert result.exit_code == 2, result.output
        lines = result.output.splitlines()
        assert len(lines) == 1, result.output
        assert lines[0].startswith(f"Error: blinkcan {words} opens no bus: --interface"), \
            result.output
