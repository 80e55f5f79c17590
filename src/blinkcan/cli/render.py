"""Drawing the devices in the terminal: a keypad's keys in its model's grid, a Keybox's outputs.
Shared by ``demo`` and ``monitor``; colours are also named, for plain terminals and logs."""

from __future__ import annotations

from collections.abc import Iterable

from rich.panel import Panel
from rich.table import Table
from rich.text import Text

STYLE = {"off": "grey35", "red": "red", "green": "green", "blue": "blue", "yellow": "yellow",
         "cyan": "cyan", "magenta": "magenta", "white": "white",
         # J1939 mode's own colour codes (§7a): shown as commanded, not as their RGB mixture
         "amber": "orange1", "yellow/green": "chartreuse2"}
#: names longer than a cell's label
SHORT = {"yellow/green": "yel/grn"}
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
    return Text(f"[{key:>2} {label:<7}]", style=f"bold {style}" + (" underline" if held else ""))


def keypad_panel(keys: Iterable[tuple[int, str, str, bool]], title: str,
                 grid: tuple[tuple[int, ...], ...]) -> Panel:
    """keys: (key, phase A colour, phase B colour, held); ``grid``: the key numbers row by row
    as the model's face shows them (0: no key)."""
    cells = {key[0]: key_cell(*key) for key in keys}
    table = Table.grid(padding=(0, 1))
    for row in grid:
        table.add_row(*(cells.get(number, Text("")) for number in row))
    return Panel(table, title=title, expand=False)


def keybox_panel(pins: Iterable[tuple[int, str, bool, int | None]], title: str) -> Panel:
    """pins: (pin, "off"/"high"/"fault", fuse blown, PWM duty in % or None)."""
    row = Text()
    for pin, state, blown, pwm in pins:
        shown = f"PWM {pwm}%" if pwm is not None and state != "fault" else state.upper()
        row.append(f" {pin}:{shown}", style=PIN_STYLE[state])
        if blown:
            row.append("(fuse blown)", style="red")
    return Panel(row, title=title, expand=False)
