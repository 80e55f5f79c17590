"""``blinkcan decode FILE [--json] [--device 0x15=keypad ...]``: what a log file means."""

from __future__ import annotations

import sys

import click
from rich.console import Console
from rich.progress import Progress, SpinnerColumn, TextColumn

from blinkcan.cli.bus_options import parse_int
from blinkcan.decode import Decoder
from blinkcan.devices.model import DeviceDescription
from blinkcan.devices.registry import describe_device
from blinkcan.formats.logs import LogError, read_frames


def parse_devices(specs: tuple[str, ...]) -> dict[int, str | DeviceDescription]:
    devices: dict[int, str | DeviceDescription] = {}
    for spec in specs:
        node_text, separator, model = spec.partition("=")
        if not separator:
            raise click.BadParameter(f"{spec!r}: write NODE=MODEL, e.g. 0x15=keypad",
                                     param_hint="--device")
        try:
            devices[parse_int(node_text)] = describe_device(model)
        except ValueError as error:
            raise click.BadParameter(str(error), param_hint="--device") from None
    return devices


@click.command("decode")
@click.argument("file", type=click.Path(dir_okay=False))
@click.option("--json", "as_json", is_flag=True, help="One JSON object per line.")
@click.option("--device", "devices", multiple=True, metavar="NODE=MODEL",
              help="Say which node is which device: 0x15=keypad, 0x0C=keybox, 0x15=keypad@1.1."
                   " Others are learned from identity traffic.")
def command(file: str, as_json: bool, devices: tuple[str, ...]) -> None:
    """Decode a log file (any python-can format, or .pcap) into what happened."""
    decoder = Decoder(parse_devices(devices))
    out = sys.stdout
    write = out.write
    progress = None
    if not as_json and sys.stderr.isatty():
        progress = Progress(SpinnerColumn(), TextColumn("{task.completed:,} frames"),
                            console=Console(stderr=True), transient=True)
    try:
        if as_json:
            json_line = decoder.json_line
            for timestamp, frame in read_frames(file):
                write(json_line(frame, timestamp) + "\n")
            return
        task = progress.add_task("decode") if progress is not None else None
        if progress is not None:
            progress.start()
        for count, (timestamp, frame) in enumerate(read_frames(file), start=1):
            ident = f"{frame.can_id:08X}" if frame.extended else f"{frame.can_id:03X}"
            write(f"{timestamp:17.6f}  {ident:>8}  {frame.data.hex(' ').upper():<23}  "
                  f"{decoder.decode(frame, timestamp)}\n")
            if progress is not None and task is not None and count % 5000 == 0:
                progress.update(task, completed=count)
    except LogError as error:
        raise click.ClickException(str(error)) from None
    except BrokenPipeError:
        sys.stderr.close()
    finally:
        if progress is not None:
            progress.stop()
