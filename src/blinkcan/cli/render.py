"""Drawing the devices in the terminal: a keypad's keys in its model's grid, a Keybox's outputs.
Shared by ``demo`` and ``monitor``; colours are also named, for plain terminals and logs.
Every picture fits 80 columns (the widest grid, six keys a row, takes 79); off a terminal the
commands write plain lines instead (:func:`output_console`)."""

from __future__ import annotations

from collections.abc import Iterable

from rich.columns import Columns
from rich.console import Console
from rich.panel import Panel
from rich.table import Table
from rich.text import Text

STYLE = {"off": "grey35", "red": "red", "green": "green", "blue": "blue", "yellow": "yellow",
         "cyan": "cyan", "magenta": "magenta", "white": "white",
         # J1939 mode's own colour codes (§7a): shown as commanded, not as their RGB mixture
         "amber": "orange1", "yellow/green": "chartreuse2"}
#: names longer than a cell's label
SHORT = {"yellow/green": "yel/grn"}
#: a key's label is cut to this, so every cell of a grid has one width ("[12 ~magent]")
LABEL = 7
PIN_STYLE = {"off": "grey50", "high": "bold green", "fault": "bold red"}


def key_cell(key: int, phase_a: str, phase_b: str, held: bool = False) -> Text:
    """A key by the colours of its two blink phases (devices/colours.blink_phases): "[ 4
    green]" steady, "[ 4 ~red]" blinking, "[ 4 red/grn]" alternating; held keys underlined."""
    if phase_a == phase_b:
        label = "" if phase_a == "off" else SHORT.get(phase_a, phase_a)
        style = STYLE.get(phase_a, "white")
    elif "off" in (phase_a, phase_b):
        colour = phase_b if phase_a == "off" else phase_a
        label, style = f"~{SHORT.get(colour, colour)}", STYLE.get(colour, "white")
    else:
        label, style = f"{phase_a[:3]}/{phase_b[:3]}", STYLE.get(phase_a, "white")
    return Text(f"[{key:>2} {label[:LABEL]:<{LABEL}}]",
                style=f"bold {style}" + (" underline" if held else ""))


def keypad_panel(keys: Iterable[tuple[int, str, str, bool]], title: str,
                 grid: tuple[tuple[int, ...], ...]) -> Panel:
    """keys: (key, phase A colour, phase B colour, held); ``grid``: the key numbers row by row
    as the model's face shows them (0: no key)."""
    cells = {key[0]: key_cell(*key) for key in keys}
    table = Table.grid(padding=(0, 1))
    for row in grid:
        table.add_row(*(cells.get(number, Text("")) for number in row))
    return Panel(table, title=title, expand=False, padding=0)


def keybox_panel(pins: Iterable[tuple[int, str, bool, int | None]], title: str) -> Panel:
    """pins: (pin, "off"/"high"/"fault", fuse blown, PWM duty in % or None); as many a row as
    the console's width takes, a pin never split."""
    cells = []
    for pin, state, blown, pwm in pins:
        shown = f"PWM {pwm}%" if pwm is not None and state != "fault" else state.upper()
        cell = Text(f"{pin}:{shown}", style=PIN_STYLE[state])
        if blown:
            cell.append("(fuse blown)", style="red")
        cells.append(cell)
    return Panel(Columns(cells), title=title, expand=False)


def output_console(stderr: bool = False) -> Console:
    """The console a command prints on: on a terminal, rich fits its width; elsewhere (a pipe,
    a file) lines are written whole, never wrapped, for grep and logs."""
    console = Console(highlight=False, stderr=stderr)
    console.soft_wrap = not console.is_terminal
    return console
