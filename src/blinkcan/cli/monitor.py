"""``blinkcan monitor``: live view of a bus, updated in place: the events (repeated heartbeats
folded, times from the first event), each keypad's keys and LEDs (blinking and alternating as
the keypad shows them), each Keybox's outputs (PWM pins with their duty). ``--file`` replays a
log at its own pace (``--speed``) instead of a live bus. Without ``--device`` the keypad is
assumed at 15h and the Keybox at 0Ch, and it says so."""

from __future__ import annotations

import time
from collections.abc import Callable

import can
import click
from rich.console import Console, Group
from rich.live import Live
from rich.table import Table
from rich.text import Text

from blinkcan.cli.bus_faults import BusFaults, receive
from blinkcan.cli.bus_options import bus_options, cli_bus
from blinkcan.cli.decode import assumed_text, other_event, parse_devices
from blinkcan.cli.render import keybox_panel, keypad_panel
from blinkcan.decode import Decoder
from blinkcan.decode.eventlog import EventLog
from blinkcan.decode.view import BusView
from blinkcan.formats.logs import LogError, read_log
from blinkcan.protocol.frame import Frame
from blinkcan.runtime import to_frame


def render(view: BusView, log: EventLog) -> Group:
    parts: list[object] = []
    for node in sorted(view.nodes.values(), key=lambda n: n.node_id):
        title = f"{node.device or 'node'} {node.node_id:02X}h, {node.state}"
        if node.face.keys:  # what the model's face has: keys with LEDs, outputs
            keys = ((k, a, b, k in node.held) for k, a, b in node.key_phases())
            parts.append(keypad_panel(keys, title, node.face.grid))
        if node.face.pins:
            pins = ((pin, state, False, node.pwm.get(pin)) for pin, state in node.outputs.items())
            parts.append(keybox_panel(pins, title))
        if node.other:  # what the model sends besides keys and outputs: knobs, inputs...
            parts.append(Text("\n".join(node.other.values())))
    table = Table("s", "id", "data", "meaning", title="events (s from the first)",
                  title_justify="left")
    for row in log.rows:
        frame = row.event.frame
        ident = f"{frame.can_id:08X}" if frame.extended else f"{frame.can_id:03X}"
        table.add_row(f"{log.since_start(row.event):.3f}", ident, frame.data.hex(" ").upper(),
                      row.text())
    parts.append(table)
    return Group(*parts)  # type: ignore[arg-type]


def replay_wait(first: float, frame_time: float, started: float, now: float,
                speed: float) -> float:
    """Seconds to wait before showing a logged frame: the log's own pace divided by
    ``speed`` (0: no wait at all)."""
    if speed <= 0:
        return 0.0
    return max(0.0, started + (frame_time - first) / speed - now)


@click.command("monitor")
@click.option("--device", "devices", multiple=True, metavar="NODE=MODEL",
              help="Which node is which device (default: keypad 15h, Keybox 0Ch; others "
                   "learned from identity traffic).")
@click.option("--file", "log_file", type=click.Path(dir_okay=False), default=None,
              help="Replay a log file instead of a live bus.")
@click.option("--speed", type=click.FloatRange(min=0.0), default=1.0, show_default=True,
              help="--file: replay at this many times the log's pace (0: the final state at "
                   "once).")
@click.option("--duration", type=click.FloatRange(min=0.0), default=None,
              help="Stop after this many seconds.")
@click.option("--rows", type=click.IntRange(min=1), default=15, show_default=True,
              help="Events shown (repeated heartbeats fold into one row).")
@bus_options
def command(devices: tuple[str, ...], log_file: str | None, speed: float,
            duration: float | None, rows: int) -> None:
    """Watch a bus live: events, keypad keys and LEDs, Keybox outputs. Ctrl-C stops. A bus
    error is counted and the watching goes on; a bus that keeps failing ends it."""
    known = parse_devices(devices)
    if not devices:
        click.echo(assumed_text(known), err=True)
    decoder = Decoder(known)
    view = BusView(decoder)
    log = EventLog(rows)
    console = Console(highlight=False)

    def feed(frame_time: float, item: Frame | can.Message) -> None:
        event = decoder.decode(item, frame_time) if isinstance(item, Frame) else \
            other_event(decoder, item)
        view.update(event)
        log.add(event)

    if log_file is not None:
        _replay(log_file, speed, duration, feed, lambda: render(view, log), console)
        return
    bus = cli_bus()
    end = None if duration is None else time.monotonic() + duration
    faults = BusFaults()
    try:
        with Live(render(view, log), console=console, auto_refresh=False) as live:
            shown = time.monotonic()
            while end is None or time.monotonic() < end:
                message = receive(bus, 0.05, faults, live.console.print)
                if message is not None:
                    frame = to_frame(message)
                    feed(message.timestamp, frame if frame is not None else message)
                elif faults.given_up():
                    break
                if time.monotonic() - shown > 0.1:  # at most ten redraws a second
                    live.update(render(view, log), refresh=True)
                    shown = time.monotonic()
            live.update(render(view, log), refresh=True)
    except KeyboardInterrupt:
        pass
    finally:
        bus.shutdown()
    if (errors := faults.summary()) is not None:
        click.echo(errors, err=True)
    if faults.given_up():
        raise click.ClickException(faults.give_up_text())


def _replay(log_file: str, speed: float, duration: float | None,
            feed: Callable[[float, Frame | can.Message], None],
            picture: Callable[[], Group], console: Console) -> None:
    """Feed a log's frames at their own pace (times ``speed``), redrawing as they come."""
    started = time.monotonic()
    end = None if duration is None else started + duration
    first: float | None = None
    try:
        with Live(picture(), console=console, auto_refresh=False) as live:
            shown = started
            for frame_time, item in read_log(log_file):
                first = frame_time if first is None else first
                wait = replay_wait(first, frame_time, started, time.monotonic(), speed)
                if end is not None and time.monotonic() + wait > end:
                    break
                if wait > 0:
                    live.update(picture(), refresh=True)  # what was true until now
                    time.sleep(wait)
                    shown = time.monotonic()
                feed(frame_time, item)
                if speed > 0 and time.monotonic() - shown > 0.1:
                    live.update(picture(), refresh=True)
                    shown = time.monotonic()
            live.update(picture(), refresh=True)
    except LogError as error:
        raise click.ClickException(str(error)) from None
    except KeyboardInterrupt:
        pass
