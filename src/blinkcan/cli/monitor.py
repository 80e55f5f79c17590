"""``blinkcan monitor``: live view of a bus, updated in place: the events (repeated heartbeats
and unchanged periodic frames folded), each keypad's keys and LEDs (blinking and alternating as
the keypad shows them), each Keybox's outputs (PWM pins with their duty). ``--file`` replays a
log at its own pace (``--speed``) instead of a live bus. Without ``--device`` it assumes the
devices ``decode`` does (cli/decode.py assumed_devices), and it says so. Times: seconds since
the first frame, ``--absolute`` the wall clock (cli/clock.py). Off a terminal (a pipe, a file)
there is no picture: each event is one line, as ``decode`` writes it. A reader that closes
the pipe (``| head -2``) ends the watching, exit 0, as it ends ``decode``: the reader's choice.
"""

from __future__ import annotations

import contextlib
import os
import sys
import time
from collections.abc import Callable, Iterator

import can
import click
from rich.console import Console, Group
from rich.live import Live
from rich.table import Table
from rich.text import Text

from blinkcan.cli.bus_faults import BusFaults, receive
from blinkcan.cli.bus_options import bus_options, cli_bus, given_bus_options
from blinkcan.cli.clock import ABSOLUTE, Clock
from blinkcan.cli.decode import (
    DEVICE_HELP,
    AssumingHelp,
    assumed_text,
    other_event,
    parse_devices,
)
from blinkcan.cli.extras import error_text
from blinkcan.cli.render import keybox_panel, keypad_panel
from blinkcan.cli.seconds import Factor, Seconds
from blinkcan.cli.whole import Whole
from blinkcan.decode import Decoder, Event
from blinkcan.decode.eventlog import EventLog
from blinkcan.decode.view import BusView
from blinkcan.errors import BlinkcanError
from blinkcan.formats.logs import LogError, read_log
from blinkcan.formats.unreadable import UnreadableCount, UnreadableLine
from blinkcan.protocol.frame import Frame
from blinkcan.runtime import to_frame


class _ReaderGoneError(BlinkcanError):
    """The reader of stdout closed it (``| head -2``): nothing more to show anyone."""


class _OutputConsole(Console):
    """cli/render.py's ``output_console``, whose broken pipe ends the watching: rich's own
    answer exits 1 in silence (``SystemExit(1)``), where a closed pipe is the reader's choice."""

    def __init__(self) -> None:
        super().__init__(highlight=False)
        self.soft_wrap = not self.is_terminal  # whole lines off a terminal, as output_console

    def on_broken_pipe(self) -> None:
        self.quiet = True  # stdout to nowhere: the interpreter's last flush finds no pipe
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        raise _ReaderGoneError


def render(view: BusView, log: EventLog, clock: Clock | None = None) -> Group:
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
    clock = clock if clock is not None else Clock(start=log.start)
    table = Table("UTC" if clock.absolute else "s", "id", "data", "meaning",
                  title="events" if clock.absolute else "events (s from the first frame)",
                  title_justify="left")
    for row in log.rows:
        frame = row.event.frame
        table.add_row(clock(row.event.time), _ident(frame), frame.data.hex(" ").upper(),
                      row.text())
    parts.append(table)
    return Group(*parts)  # type: ignore[arg-type]


def _ident(frame: Frame) -> str:
    return f"{frame.can_id:08X}" if frame.extended else f"{frame.can_id:03X}"


def event_line(time_text: str, event: Event) -> str:
    """One event as one plain line, the way ``decode`` writes it."""
    frame = event.frame
    return f"{time_text:>12}  {_ident(frame):>8}  {frame.data.hex(' ').upper():<23}  {event}"


class _Lines:
    """Off a terminal, Live's stand-in: no picture (the events go out as lines)."""

    def update(self, *_: object, **__: object) -> None:
        return None


@contextlib.contextmanager
def _screen(picture: Callable[[], Group], console: Console) -> Iterator[Live | _Lines]:
    """The picture updated in place on a terminal; nothing to draw elsewhere."""
    if not console.is_terminal:
        yield _Lines()
        return
    with Live(picture(), console=console, auto_refresh=False) as live:
        yield live


def replay_wait(first: float, frame_time: float, started: float, now: float,
                speed: float) -> float:
    """Seconds to wait before showing a logged frame: the log's own pace divided by
    ``speed`` (0: no wait at all)."""
    if speed <= 0:
        return 0.0
    return max(0.0, started + (frame_time - first) / speed - now)


@click.command("monitor", cls=AssumingHelp)
@click.option("--device", "devices", multiple=True, metavar="NODE=MODEL", help=DEVICE_HELP)
@click.option("--file", "log_file", type=click.Path(dir_okay=False), default=None,
              help="Replay a log file instead of a live bus.")
@click.option("--speed", type=Factor(), default=1.0, show_default=True,
              help="--file: replay at this many times the log's pace (0: the final state at "
                   "once).")
@click.option("--duration", type=Seconds(), default=None,
              help="Stop after this many seconds.")
@click.option("--rows", type=Whole(1, 1000), default=15, show_default=True,
              help="Events shown (repeated heartbeats fold into one row).")
@ABSOLUTE
@bus_options
def command(devices: tuple[str, ...], log_file: str | None, speed: float,
            duration: float | None, rows: int, absolute: bool) -> None:
    """Watch a bus live: events, keypad keys and LEDs (CANopen or J1939 mode), Keybox
    outputs, and what else a device sends (encoders, analog and digital inputs). Without
    --device it assumes {assumed}. Ctrl-C stops. A bus error is counted and the watching goes
    on; a bus that keeps failing ends it. Off a terminal: one line per event."""
    if log_file is not None and (given := given_bus_options(click.get_current_context())):
        # a log opens no bus: an option taken in silence would let the user believe they
        # watched the bus it names (cli/main.py refuses them the same way for decode)
        raise click.UsageError(f"blinkcan monitor --file reads a log and opens no bus: "
                               f"{', '.join(given)} do{'es' if len(given) == 1 else ''} "
                               "not apply")
    known = parse_devices(devices)
    if not devices:
        click.echo(assumed_text(), err=True)
    decoder = Decoder(known, assumed=not devices)
    view = BusView(decoder)
    log = EventLog(rows, decoder)
    console = _OutputConsole()
    clock = Clock(absolute)
    lines = not console.is_terminal

    def feed(frame_time: float, item: Frame | can.Message) -> None:
        event = decoder.decode(item, frame_time) if isinstance(item, Frame) else \
            other_event(decoder, item)
        time_text = clock(event.time)  # the first frame starts the clock
        view.update(event)
        log.add(event)
        if lines:
            console.out(event_line(time_text, event), highlight=False)

    def picture() -> Group:
        return render(view, log, clock)

    if log_file is not None:
        with contextlib.suppress(_ReaderGoneError):
            _replay(log_file, speed, duration, feed, picture, console)
        return
    bus = cli_bus()
    end = None if duration is None else time.monotonic() + duration
    faults = BusFaults()
    try:
        with _screen(picture, console) as live:
            shown = time.monotonic()
            while end is None or time.monotonic() < end:
                message = receive(bus, 0.05, faults, console.print)
                if message is not None:
                    frame = to_frame(message)
                    feed(message.timestamp, frame if frame is not None else message)
                elif faults.given_up():
                    break
                if time.monotonic() - shown > 0.1:  # at most ten redraws a second
                    live.update(picture(), refresh=True)
                    shown = time.monotonic()
            live.update(picture(), refresh=True)
    except (KeyboardInterrupt, _ReaderGoneError):
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
    unreadable = UnreadableCount()
    try:
        with _screen(picture, console) as live:
            shown = started
            for frame_time, item in read_log(log_file):
                if isinstance(item, UnreadableLine):  # no frame: named and counted below
                    unreadable.add(item)
                    continue
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
        raise click.ClickException(error_text(error)) from None
    except KeyboardInterrupt:
        pass
    finally:
        for line in unreadable.named:
            click.echo(f"{log_file}: {line}", err=True)
        if unreadable.count:
            click.echo(unreadable.summary(log_file, "skipped"), err=True)
