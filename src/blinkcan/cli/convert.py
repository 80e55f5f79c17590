"""``blinkcan convert IN OUT`` and ``blinkcan record OUT``: CAN logs between formats, and from
a live bus. Formats by file name: .pcap, or any python-can log format (.asc .blf .log .trc
.csv .db .mf4)."""

from __future__ import annotations

import time

import click

from blinkcan.cli.bus_options import bus_options, cli_bus
from blinkcan.cli.targets import check_target, writing
from blinkcan.formats.logs import FrameWriter, LogError, read_frames
from blinkcan.runtime import to_frame


@click.command("convert")
@click.argument("source", type=click.Path(dir_okay=False))
@click.argument("target", type=click.Path(dir_okay=False))
@click.option("--force", is_flag=True, help="Replace TARGET if it exists.")
def convert(source: str, target: str, force: bool) -> None:
    """Convert a CAN log to another format (by file name), e.g. candump .log to .pcap."""
    check_target(target, force)
    try:
        with writing(target), FrameWriter(target, replace=force) as writer:
            for timestamp, frame in read_frames(source):
                writer.write(timestamp, frame)
    except LogError as error:
        raise click.ClickException(str(error)) from None
    click.echo(f"{writer.count} frames written to {target}", err=True)


@click.command("record")
@click.argument("target", type=click.Path(dir_okay=False))
@click.option("--duration", type=float, default=None, help="Seconds to record (default: Ctrl-C).")
@click.option("--force", is_flag=True, help="Replace TARGET if it exists.")
@bus_options
def record(target: str, duration: float | None, force: bool) -> None:
    """Record a live bus to a file: .pcap for Wireshark, or any python-can log format."""
    check_target(target, force)
    bus = cli_bus()
    end = None if duration is None else time.monotonic() + duration
    try:
        with writing(target), FrameWriter(target, replace=force) as writer:
            click.echo(f"recording {bus.channel_info} to {target}; Ctrl-C stops", err=True)
            try:
                while end is None or time.monotonic() < end:
                    message = bus.recv(0.2)
                    if message is not None and (frame := to_frame(message)) is not None:
                        writer.write(message.timestamp, frame)
            except KeyboardInterrupt:
                pass
    except LogError as error:
        raise click.ClickException(str(error)) from None
    finally:
        bus.shutdown()
    click.echo(f"{writer.count} frames recorded", err=True)
