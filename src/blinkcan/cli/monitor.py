"""``blinkcan monitor``: live view of a bus, updated in place: the events, each keypad's keys
and LEDs, each Keybox's 13 outputs. ``--file`` replays a log instead of a live bus."""

from __future__ import annotations

import time
from collections import deque

import click
from rich.console import Console, Group
from rich.live import Live
from rich.table import Table
from rich.text import Text

from blinkcan.cli.bus_options import bus_options, cli_bus
from blinkcan.cli.decode import parse_devices
from blinkcan.cli.render import keybox_panel, keypad_panel
from blinkcan.decode import Decoder, Event
from blinkcan.decode.view import BusView
from blinkcan.formats.logs import LogError, read_frames
from blinkcan.protocol.frame import Frame
from blinkcan.runtime import to_frame


def render(view: BusView, events: deque[Event]) -> Group:
    parts: list[object] = []
    for node in sorted(view.nodes.values(), key=lambda n: n.node_id):
        title = f"{node.device or 'node'} {node.node_id:02X}h, {node.state}"
        if node.device == "keypad":
            keys = ((k, lit, blink, k in node.held) for k, lit, blink in node.key_colours())
            parts.append(keypad_panel(keys, title, node.face.grid))
        elif node.device == "keybox":
            pins = ((pin, state, False) for pin, state in node.outputs.items())
            parts.append(keybox_panel(pins, title))
        if node.other:  # what the model sends besides keys and outputs: knobs, inputs...
            parts.append(Text("\n".join(node.other.values())))
    table = Table("time", "id", "data", "meaning", title="events", title_justify="left")
    for event in events:
        frame = event.frame
        table.add_row(f"{event.time:.3f}", f"{frame.can_id:03X}", frame.data.hex(" ").upper(),
                      str(event))
    parts.append(table)
    return Group(*parts)  # type: ignore[arg-type]


@click.command("monitor")
@click.option("--device", "devices", multiple=True, metavar="NODE=MODEL",
              help="Which node is which device (else learned from identity traffic).")
@click.option("--file", "log_file", type=click.Path(dir_okay=False), default=None,
              help="Replay a log file instead of a live bus.")
@click.option("--duration", type=click.FloatRange(min=0.0), default=None,
              help="Stop after this many seconds.")
@click.option("--rows", type=click.IntRange(min=1), default=15, show_default=True,
              help="Events shown.")
@bus_options
def command(devices: tuple[str, ...], log_file: str | None, duration: float | None,
            rows: int) -> None:
    """Watch a bus live: events, keypad keys and LEDs, Keybox outputs. Ctrl-C stops."""
    decoder = Decoder(parse_devices(devices))
    view = BusView(decoder)
    events: deque[Event] = deque(maxlen=rows)
    console = Console(highlight=False)

    def feed(frame_time: float, frame: Frame) -> None:
        event = decoder.decode(frame, frame_time)
        view.update(event)
        events.append(event)

    if log_file is not None:
        try:
            for frame_time, logged in read_frames(log_file):
                feed(frame_time, logged)
        except LogError as error:
            raise click.ClickException(str(error)) from None
        console.print(render(view, events))
        return
    bus = cli_bus()
    end = None if duration is None else time.monotonic() + duration
    try:
        with Live(render(view, events), console=console, auto_refresh=False) as live:
            shown = time.monotonic()
            while end is None or time.monotonic() < end:
                message = bus.recv(0.05)
                if message is not None and (live_frame := to_frame(message)) is not None:
                    feed(message.timestamp, live_frame)
                if time.monotonic() - shown > 0.1:  # at most ten redraws a second
                    live.update(render(view, events), refresh=True)
                    shown = time.monotonic()
            live.update(render(view, events), refresh=True)
    except KeyboardInterrupt:
        pass
    finally:
        bus.shutdown()
