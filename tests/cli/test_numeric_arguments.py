"""Every number a command line takes is checked before anything opens (DESIGN: the CLI checks
arguments before it touches the bus, one line ``Error: ...`` naming the valid range, non-zero
exit). Swept over every option and argument of every subcommand that takes a number, found by
walking the click commands (a new one joins by itself, or fails
:func:`test_every_number_the_command_line_takes_is_swept` until it is given valid neighbours
in :data:`VALID`). Found by the attack pass of session 5: ``emulate --response-delay 1e300``
was accepted (the twins never answered), ``monitor --rows 1e23`` crashed with an
OverflowError, ``-b -1`` reached python-can, ``keybox on -1`` said "No such option '-1'"."""

from __future__ import annotations

import re
from collections.abc import Iterator
from pathlib import Path

import click
import pytest
from click.testing import CliRunner

from blinkcan.cli.control import J1939Address, ModelNumber
from blinkcan.cli.main import SUBCOMMANDS, cli, load_subcommand
from blinkcan.cli.seconds import Seconds
from blinkcan.cli.whole import Whole

BAD = ["nan", "inf", "-1", "1e300", str(10**30)]
NO_BUS = ["-i", "no-such-interface"]  # reaching the bus would be another error
#: a range as the messages name it: 1..13, 0x0..0xfeff, 01h..7Fh, 0..10 seconds, "one of"
RANGE = re.compile(r"\w+\.\.\w+|one of")

#: valid words for each command's arguments, in order (LOG and OUT: files of the test)
VALID: dict[tuple[str, ...], list[str]] = {
    ("act",): ["press", "3"],
    ("decode",): ["LOG", "--parquet", "OUT"],
    ("demo",): [],
    ("emulate",): ["keypad"],
    ("export",): ["keypad"],
    ("monitor",): [],
    ("record",): ["OUT"],
    ("scan",): [],
    ("keybox",): ["states"],
    ("keybox", "heartbeat"): ["100"],
    ("keybox", "on"): ["4"],
    ("keybox", "off"): ["4"],
    ("keybox", "reset"): ["4"],
    ("keybox", "pwm"): ["12", "5"],
    ("keybox", "set-baud"): ["250000", "--yes"],
    ("keybox", "set-node-id"): ["13", "--yes"],
    ("keybox", "write"): ["fault_period", "10"],
    ("keypad",): ["info"],
    ("keypad", "heartbeat"): ["100"],
    ("keypad", "backlight"): [],
    ("keypad", "brightness"): ["10"],
    ("keypad", "encoder"): ["1"],
    ("keypad", "led"): ["3", "red"],
    ("keypad", "ring"): ["1", "1,2"],
    ("keypad", "set-baud"): ["250000", "--yes"],
    ("keypad", "set-node-id"): ["22", "--yes"],
    ("keypad", "write"): ["backlight_brightness", "10"],
    ("nmt", "start"): ["all"], ("nmt", "stop"): ["all"], ("nmt", "reset"): ["all"],
    ("nmt", "pre-operational"): ["all"], ("nmt", "reset-communication"): ["all"],
}
#: arguments typed as text that hold numbers (lists, or a number or a word): swept too
TEXT_NUMBERS: dict[tuple[str, ...], set[str]] = {
    ("keybox", "pwm"): {"pins", "duty"}, ("keypad", "ring"): {"leds"},
                ("keybox", "set-node-id"): {"new_id_text"},
                ("keypad", "set-node-id"): {"new_id_text"},
                ("keybox", "write"): {"value"}, ("keypad", "write"): {"value"},
                **{("nmt", name): {"node"} for name in ("start", "stop", "reset",
                                                        "pre-operational",
                                                        "reset-communication")}}
CHECKED_TYPES = (Seconds, Whole, ModelNumber, J1939Address, click.IntRange, click.FloatRange)


def _commands() -> Iterator[tuple[tuple[str, ...], click.Command]]:
    """Every command and group under ``blinkcan``, by its path."""
    context = click.Context(cli)
    for name in SUBCOMMANDS:
        command = load_subcommand(name)
        yield (name,), command
        if isinstance(command, click.Group):
            for sub in command.list_commands(context):
                found = command.get_command(context, sub)
                assert found is not None
                yield (name, sub), found


#: the bus options are one decorator (cli/bus_options.py): its -b is swept on these commands
BITRATE_SWEPT = {("scan",), ("emulate",), ("keybox",)}


def _is_number(path: tuple[str, ...], param: click.Parameter) -> bool:
    if isinstance(param, click.Option) and (param.is_flag or param.count):
        return False
    if param.name == "bitrate" and path not in BITRATE_SWEPT:
        return False
    if param.name == "node_id" and len(path) == 2 and path[0] in ("keypad", "keybox"):
        return False  # ``keypad led --node-id``: the group's option again, swept there
    number_type = isinstance(param.type, (*CHECKED_TYPES, click.types._NumberParamTypeBase))
    return number_type or (param.name or "") in TEXT_NUMBERS.get(path, set()) or \
        param.type.name in ("NODE",)


def _cases() -> Iterator[tuple[tuple[str, ...], str]]:
    for path, command in _commands():
        for param in command.params:
            if _is_number(path, param):
                yield path, str(param.name)


CASES = sorted(set(_cases()))


def test_every_number_the_command_line_takes_is_swept() -> None:
    assert len(CASES) > 40, CASES
    for path, command in _commands():
        numbers = [p for p in command.params if _is_number(path, p)]
        if numbers:
            assert path in VALID, f"give the valid arguments of {' '.join(path)} in VALID"
        for param in numbers:  # click's own int/float take 1e300 and nan unchecked
            bare = (click.types.IntParamType, click.types.FloatParamType)
            assert type(param.type) not in bare, \
                f"{' '.join(path)} {param.name}: a bare {param.type.name}, no range"


def _line(path: tuple[str, ...], name: str, value: str, tmp_path: Path) -> list[str]:
    """The command line with every word valid but ``name``'s, which is ``value``."""
    group = path[0]
    command = dict(_commands())[path]
    words = [str(tmp_path / "bus.log") if w == "LOG" else str(tmp_path / "out") if w == "OUT"
             else w for w in VALID[path]]
    param = next(p for p in command.params if p.name == name)
    if isinstance(param, click.Argument):
        position = [p.name for p in command.params if isinstance(p, click.Argument)].index(name)
        words[position] = value
        options: list[str] = []
    else:
        options = [param.opts[0], value]
    bus = NO_BUS if any(p.name == "interface" for p in command.params) else []
    if isinstance(command, click.Group):  # its options, then a command of the group
        return [group, *options, *words, *bus]
    return [*path, *options, *words, *bus]


@pytest.mark.parametrize("value", BAD)
@pytest.mark.parametrize(("path", "name"), CASES, ids=[" ".join(p) + ":" + n for p, n in CASES])
def test_a_bad_number_is_one_line_naming_the_range_before_the_bus(
        tmp_path: Path, path: tuple[str, ...], name: str, value: str) -> None:
    (tmp_path / "bus.log").write_text("(1.000000) vcan0 18A#0000000001\n")
    line = _line(path, name, value, tmp_path)
    result = CliRunner().invoke(cli, line, env={"COLUMNS": "200"})
    lines = [text for text in result.output.splitlines() if text.strip()]
    assert result.exit_code != 0, (line, result.output)
    assert len(lines) == 1, (line, result.output)
    assert lines[0].startswith("Error: "), (line, result.output)
    assert "cannot open the bus" not in lines[0]  # refused before the bus
    assert "unexpected" not in lines[0], lines[0]
    assert "No such option" not in lines[0], lines[0]
    assert RANGE.search(lines[0]), f"{' '.join(line)}: no range named in {lines[0]!r}"
    assert not (tmp_path / "out").exists()  # nothing written either
