"""``blinkcan convert IN OUT`` and ``blinkcan record OUT``: CAN logs between formats, and from
a live bus. Formats by file name: .pcap, or any python-can log format (.asc .blf .log .trc
.csv .db .mf4)."""

from __future__ import annotations

import signal
import threading
import time

import can
import click

from blinkcan.cli.bus_faults import BusFaults, receive
from blinkcan.cli.bus_options import bus_options, bus_settings, cli_bus, describe_bus
from blinkcan.cli.extras import error_text
from blinkcan.cli.seconds import Seconds
from blinkcan.cli.targets import check_target, writing
from blinkcan.errors import BlinkcanError
from blinkcan.formats.logs import FrameWriter, LogError, read_messages
from blinkcan.formats.unreadable import UnreadableCount, UnreadableLine


@click.command("convert")
@click.argument("source", type=click.Path(dir_okay=False))
@click.argument("target", type=click.Path(dir_okay=False))
@click.option("--force", is_flag=True, help="Replace TARGET if it exists.")
def convert(source: str, target: str, force: bool) -> None:
    """Convert a CAN log to another format (by file name), e.g. candump .log to .pcap.
    Every frame is kept whole (identifier, kind, flags, data, channel, time) where TARGET's
    format can hold it; what it cannot (e.g. .csv: channel, CAN FD flags) is counted, named
    and explained, one line each; a frame it cannot hold at all (.trc: error frames) refuses
    the conversion, naming how many, and nothing is written. A line of SOURCE that is no
    frame is named and counted, the frames after it converted, and the exit status is 1 (no
    format holds such a line)."""
    check_target(target, force)
    unread: LogError | None = None
    unreadable = UnreadableCount()
    try:
        with writing(target), FrameWriter(target, replace=force) as writer:
            try:
                for message in read_messages(source, unreadable=True):
                    if isinstance(message, UnreadableLine):
                        unreadable.add(message)
                    else:
                        writer.write_message(message)
            except LogError as error:
                if not writer.count:
                    raise  # nothing read: no file at all
                # the frames before what ended the reading are kept (a pcap packet whose
                # length is no frame's: the packets after it cannot be found)
                unread = error
            if writer.skipped:  # frames TARGET cannot hold: refused, TARGET left as it was
                raise writer.refusal(source)
    except LogError as error:
        for bad in unreadable.named:
            click.echo(f"{source}: {bad}", err=True)
        raise click.ClickException(error_text(error)) from None
    click.echo(f"{writer.count} frames written to {target}", err=True)
    for line in writer.lost_lines():
        click.echo(line, err=True)
    if unread is not None:
        raise click.ClickException(f"{unread}; the {writer.count} frames before it are in "
                                   f"{target}")
    if unreadable.count:
        for bad in unreadable.named:
            click.echo(f"{source}: {bad}", err=True)
        # a candump comment would hold the line, but readers skip comments: it would be
        # hidden again, so the exit status says it
        raise click.ClickException(unreadable.summary(
            source, f"not in {target}, which holds frames only", writer.count))


class _StopError(BlinkcanError):
    """SIGTERM (or SIGINT) asked the recording to stop."""


def _raise_stop(signum: int, frame: object) -> None:
    raise _StopError


@click.command("record")
@click.argument("target", type=click.Path(dir_okay=False))
@click.option("--duration", type=Seconds(), default=None,
              help="Seconds to record (default: Ctrl-C).")
@click.option("--force", is_flag=True, help="Replace TARGET if it exists.")
@bus_options
def record(target: str, duration: float | None, force: bool) -> None:
    """Record a live bus to a file: .pcap for Wireshark, or any python-can log format.
    Frames are streamed to disk; Ctrl-C or SIGTERM stops and keeps everything so far. A bus
    error (e.g. a datagram that is not a frame) is counted and the recording goes on; a bus
    that keeps failing ends it, and what was recorded is kept."""
    check_target(target, force)
    bus = cli_bus()
    end = None if duration is None else time.monotonic() + duration
    faults = BusFaults()
    previous = {}
    if threading.current_thread() is threading.main_thread():  # signals reach the main thread
        previous = {number: signal.signal(number, _raise_stop)
                    for number in (signal.SIGINT, signal.SIGTERM)}
    try:
        with writing(target, "what was recorded up to its last flush is in it"), \
                FrameWriter(target, replace=force, live=True) as writer:
            click.echo(f"recording {describe_bus(bus_settings())} to {target}; Ctrl-C stops",
                       err=True)
            try:
                _record(bus, writer, end, faults)
            except (KeyboardInterrupt, _StopError):
                pass
            finally:
                for number, handler in previous.items():  # the closing is not interrupted
                    signal.signal(number, handler)
    except LogError as error:
        raise click.ClickException(error_text(error)) from None
    finally:
        for number, handler in previous.items():
            signal.signal(number, handler)
        bus.shutdown()
    click.echo(f"{writer.count} frames recorded", err=True)
    if (skipped := writer.skipped_text()) is not None:
        click.echo(skipped, err=True)
    for line in writer.lost_lines():
        click.echo(line, err=True)
    if (errors := faults.summary()) is not None:
        click.echo(errors, err=True)
    if faults.given_up():
        raise click.ClickException(f"{faults.give_up_text()}; the {writer.count} frames "
                                   f"recorded until then are in {target}")


def _record(bus: can.BusABC, writer: FrameWriter, end: float | None,
            faults: BusFaults) -> None:
    """Write what the bus says until ``end`` (or for ever), or until it keeps failing."""
    flushed = time.monotonic()
    while end is None or time.monotonic() < end:
        message = receive(bus, 0.2, faults, lambda text: click.echo(text, err=True))
        if message is not None:
            writer.write_message(message)
        elif faults.given_up():
            return
        if time.monotonic() - flushed > 1.0:  # at most a second lost on a crash
            writer.flush()
            flushed = time.monotonic()
