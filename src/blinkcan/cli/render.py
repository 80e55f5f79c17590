"""Drawing the devices in the terminal: a keypad's keys in its model's grid, a Keybox's outputs.
Shared by ``demo`` and ``monitor``; colours are also named, for plain terminals and logs."""

from __future__ import annotations

from collections.abc import Iterable

from rich.panel import Panel
from rich.table import Table
from rich.text import Text

STYLE = {"off": "grey35", "red": "red", "green": "green", "blue": "blue", "yellow": "yellow",
         "cyan": "cyan", "magenta": "magenta", "white": "white"}
PIN_STYLE = {"off": "grey50", "high": "bold green", "fault": "bold red"}


def key_cell(key: int, lit: str, blink: str, held: bool = False) -> Text:
    """"[ 4 green]", "[ 4 ~red]" for blinking; held keys underlined."""
    if blink != "off":
        label, style = f"~{blink}", STYLE[blink]
    else:
        label, style = ("" if lit == "off" else lit), STYLE[lit]
    return Text(f"[{key:>2} {label:<6}]", style=f"bold {style}" + (" underline" if held else ""))


def keypad_panel(keys: Iterable[tuple[int, str, str, bool]], title: str,
                 grid: tuple[tuple[int, ...], ...]) -> Panel:
    """keys: (key, colour, blink colour, held); ``grid``: the key numbers row by row as the
    model's face shows them (0: no key)."""
    cells = {key[0]: key_cell(*key) for key in keys}
    table = Table.grid(padding=(0, 1))
    for row in grid:
        table.add_row(*(cells.get(number, Text("")) for number in row))
    return Panel(table, title=title, expand=False)


def keybox_panel(pins: Iterable[tuple[int, str, bool]], title: str) -> Panel:
    """pins: (pin, "off"/"high"/"fault", fuse blown)."""
    row = Text()
    for pin, state, blown in pins:
        row.append(f" {pin}:{state.upper()}", style=PIN_STYLE[state])
        if blown:
            row.append("(fuse blown)", style="red")
    return Panel(row, title=title, expand=False)
