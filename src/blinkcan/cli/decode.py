"""``blinkcan decode FILE [--json] [--device 0x15=keypad ...]``: what a log file means.

The text gives each frame's time in seconds since the log's first frame (``--absolute``: the
wall clock, ISO 8601 UTC; cli/clock.py); ``--json`` keeps the log's own timestamp as ``time``,
untouched, for programs."""

from __future__ import annotations

import sys
from typing import TYPE_CHECKING

import click

from blinkcan.cli.bus_options import parse_int
from blinkcan.cli.clock import ABSOLUTE, iso_utc
from blinkcan.cli.extras import error_text
from blinkcan.cli.whole import Whole
from blinkcan.decode import Decoder, Event
from blinkcan.decode.decoder import encode_json, json_times
from blinkcan.decode.j1939 import is_j1939_node, j1939_node, parse_j1939_node
from blinkcan.decode.nodes import NodeKey, split_devices
from blinkcan.devices.keypad_j1939 import DEFAULT_ADDRESS as J1939_DEFAULT_ADDRESS
from blinkcan.devices.model import DeviceDescription
from blinkcan.devices.registry import describe_device, models
from blinkcan.formats.logs import (
    LogError,
    describe_frame,
    frame_kind,
    read_log_columns,
)
from blinkcan.formats.unreadable import UnreadableCount, UnreadableLine
from blinkcan.protocol.frame import Frame

if TYPE_CHECKING:  # a candump log decodes without python-can (start-up: issue 22)
    from collections.abc import Callable

    import can
    from rich.progress import Progress

    from blinkcan.formats.columns import FrameColumns

#: the devices assumed where no --device is given: each at its factory node id
DEFAULT_DEVICES = ("keypad", "keybox")


def default_devices() -> dict[int, str | DeviceDescription]:
    descriptions = [describe_device(name) for name in DEFAULT_DEVICES]
    return {d.default_node_id: d for d in descriptions}


def assumed_devices() -> str:
    """The devices a decoder assumes where no --device is given, read from one built so:
    "keybox 0Ch, keypad 15h and a J1939 keypad at 21h" (the stderr note and the help say it)."""
    decoder = Decoder(parse_devices(()))
    canopen = [f"{d.kind} {node:02X}h" for node, d in sorted(decoder.devices.items())]
    j1939_kinds = sorted({m.description().kind for m in models()
                          if "j1939" in m.description().features})
    j1939 = [f"a J1939 {' or '.join(j1939_kinds)} at {address:02X}h"
             for address in sorted(decoder.j1939.addresses)]
    return " and ".join(filter(None, [", ".join(canopen), *j1939]))


def assumed_text() -> str:
    """What the decoder assumes where no --device is given (stderr: the output stays data)."""
    return (f"no --device given: assuming {assumed_devices()} (others learned from identity "
            "traffic and their own messages)")


#: where a command's help says which devices it assumes (AssumingHelp fills it in)
ASSUMED = "{assumed}"


class AssumingHelp(click.Command):
    """A command whose help names the devices assumed without --device (:data:`ASSUMED`),
    from :func:`assumed_devices` when the help is shown (not at every start-up)."""

    def format_help_text(self, ctx: click.Context, formatter: click.HelpFormatter) -> None:
        self.help = (self.help or "").replace(ASSUMED, assumed_devices())
        super().format_help_text(ctx, formatter)


def other_event(decoder: Decoder, message: can.Message) -> Event:
    """The event of a frame that is not a classic data frame: remote, error, CAN FD."""
    return decoder.decode_other(frame_kind(message), message.timestamp, message.arbitration_id,
                                message.is_extended_id, message.dlc, bytes(message.data),
                                describe_frame(message))


def parse_device_specs(specs: tuple[str, ...]) -> dict[NodeKey, str]:
    """--device NODE=MODEL options as the decoder takes them: a CANopen node id (0x15=keypad)
    or a J1939 address (j1939:0x30=keypad) to a model name; checked (BadParameter)."""
    devices: dict[NodeKey, str] = {}
    for spec in specs:
        node_text, separator, model = spec.partition("=")
        if not separator:
            raise click.BadParameter(f"{spec!r}: write NODE=MODEL, e.g. 0x15=keypad or "
                                     "j1939:0x30=keypad", param_hint="--device")
        try:
            node: NodeKey
            if is_j1939_node(node_text):
                node = j1939_node(parse_j1939_node(node_text))
            else:
                node = parse_int(node_text)
            split_devices({node: model})
        except (ValueError, click.BadParameter) as error:
            message = error.message if isinstance(error, click.BadParameter) else str(error)
            raise click.BadParameter(message, param_hint="--device") from None
        devices[node] = model
    return devices


def parse_devices(specs: tuple[str, ...]) -> dict[NodeKey, str | DeviceDescription]:
    """--device options; none given: the default nodes (DEFAULT_DEVICES)."""
    if not specs:
        return dict(default_devices().items())
    return dict(parse_device_specs(specs).items())


#: --device's help, the same for decode and monitor
DEVICE_HELP = ("Say which node is which device: 0x15=keypad, 0x0C=keybox, 0x15=keypad@1.1; a "
               "keypad in J1939 mode by its source address: j1939:0x30=keypad (none named: "
               f"{J1939_DEFAULT_ADDRESS:02X}h). Others are learned from identity traffic and "
               "their own messages.")


@click.command("decode", cls=AssumingHelp)
@click.argument("files", metavar="FILE...", nargs=-1, required=True,
                type=click.Path(allow_dash=True))
@click.option("--json", "as_json", is_flag=True, help="One JSON object per line.")
@click.option("--device", "devices", multiple=True, metavar="NODE=MODEL", help=DEVICE_HELP)
@click.option("--parquet", "parquet", metavar="OUT", default=None,
              help="Decode the logs (files or folders) into the Parquet dataset OUT (a folder "
                   "or an fsspec URL): a row per event, by model and date. Needs "
                   "blinkcan[fleet].")
@click.option("-j", "--jobs", type=Whole(1, 256), default=1,
              help="With --parquet: files decoded at once, on local processes.")
@click.option("--force", is_flag=True,
              help="With --parquet: decode again files already decoded by this version.")
@ABSOLUTE
def command(files: tuple[str, ...], as_json: bool, devices: tuple[str, ...],
            parquet: str | None, jobs: int, force: bool, absolute: bool) -> None:
    """Decode a log file (any python-can format, or .pcap) into what happened; with
    --parquet, any number of them into a dataset for SQL (blinkcan query). Without
    --device it assumes {assumed}. Times: seconds since the first frame, or --absolute;
    --json keeps the log's own timestamps."""
    if absolute and (as_json or parquet is not None):
        raise click.UsageError("--absolute is for the text output; --json and --parquet keep "
                               "the log's own timestamps")
    known = parse_devices(devices)
    if parquet is not None:
        from blinkcan.cli.parquet import decode_to_parquet  # noqa: PLC0415 (pyarrow: only here)

        if as_json:
            raise click.UsageError("--json and --parquet are two outputs: choose one")
        decode_to_parquet(files, parquet, jobs, force, parse_device_specs(devices))
        return
    if len(files) != 1 or jobs != 1 or force:
        raise click.UsageError("several files, -j and --force go with --parquet OUT")
    file = files[0]
    if not devices:
        click.echo(assumed_text(), err=True)
    decoder = Decoder(known, assumed=not devices)
    progress = None
    if not as_json and sys.stderr.isatty():
        from rich.console import Console  # noqa: PLC0415 (start-up: only on a terminal)
        from rich.progress import Progress, SpinnerColumn, TextColumn  # noqa: PLC0415

        progress = Progress(SpinnerColumn(), TextColumn("{task.completed:,} frames"),
                            console=Console(stderr=True), transient=True)
    _decode_to_stdout(decoder, file, as_json, progress, absolute)


def _decode_to_stdout(decoder: Decoder, file: str, as_json: bool, progress: Progress | None,
                      absolute: bool = False) -> None:
    """Every frame's line on stdout: JSON, or the text with the frame (and a progress
    display on a terminal): its time since the first frame, or with ``absolute`` the wall
    clock. A line of the log that is no frame is in the output in its place (JSON: an
    ``unreadable`` object with its text), named on stderr and counted (issue 23)."""
    output = _Output()
    unreadable = UnreadableCount()
    try:
        if as_json:
            _json_lines(decoder, file, output, unreadable)
        else:
            _text_lines(decoder, file, output, unreadable, progress, absolute)
    except LogError as error:
        raise click.ClickException(error_text(error)) from None
    except BrokenPipeError:
        sys.stderr.close()
    finally:
        if progress is not None:
            progress.stop()
        if output.lines:  # what was decoded before an error is written before its message
            try:
                output.write()
            except BrokenPipeError:
                sys.stderr.close()
        if unreadable.count and not sys.stderr.closed:
            for line in unreadable.named:
                click.echo(f"{file}: {line}", err=True)
            click.echo(unreadable.summary(file, "in the output as 'unreadable', in place",
                                          output.written - unreadable.count), err=True)


class _Output:
    """stdout's lines, written in batches (one write per line costs a tenth of decoding)."""

    def __init__(self) -> None:
        self.lines: list[str] = []
        self.written = 0

    def write(self) -> None:
        self.written += len(self.lines)
        _write(self.lines)


def _json_lines(decoder: Decoder, file: str, output: _Output,
                unreadable: UnreadableCount) -> None:
    """A block of the log at a time: times written by one orjson call; most frames' lines
    written without a Frame or an Event: another ECU's frame (two thirds of a bus) a lookup
    of its line around time and data (Decoder.raw_json), a device's PDO or heartbeat from its
    data, a kept SDO or J1939 event's line (Decoder.json_rest); one write per block."""
    lines = output.lines
    add = lines.append
    json_line, json_rest, raw_json = decoder.json_line, decoder.json_rest, decoder.raw_json
    new = tuple.__new__  # Frame.trusted without the call: the reader checked the frames
    for block in read_log_columns(file):
        times = block.times
        if block.others:
            _json_rows(decoder, block, add, unreadable)
        else:
            for stamp, time, can_id, data, extended in zip(
                    json_times(times), times, block.ids, block.data, block.extended,
                    strict=True):
                parts = raw_json(can_id, extended)
                if parts is not None:
                    add(f'{{"time":{stamp}{parts[0]}{data.hex()}{parts[1]}')
                    continue
                rest = json_rest(can_id, extended, data, time)
                if rest is None:
                    add(json_line(new(Frame, (can_id, data, extended)), time))
                else:
                    add(f'{{"time":{stamp}{rest}')
        output.write()


def _json_rows(decoder: Decoder, block: FrameColumns, add: Callable[[str], None],
               unreadable: UnreadableCount) -> None:
    """A block with frames that are not classic data frames, or lines that are none, row by
    row."""
    others = block.others
    json_line = decoder.json_line
    for row, (time, can_id, data, extended) in enumerate(zip(
            block.times, block.ids, block.data, block.extended, strict=True)):
        other = others.get(row)
        if other is None:
            add(json_line(Frame.trusted(can_id, data, extended), time))
        elif isinstance(other, UnreadableLine):
            unreadable.add(other)
            add(encode_json(other.to_json()))
        else:
            add(encode_json(other_event(decoder, other).to_json()))


def _text_lines(decoder: Decoder, file: str, output: _Output, unreadable: UnreadableCount,
                progress: Progress | None, absolute: bool) -> None:
    """A block of the log at a time (read_log_columns: a candump log's plain blocks read
    whole); another ECU's frame's text a lookup, a PDO's written without an Event
    (Decoder.text)."""
    lines = output.lines
    add = lines.append
    task = progress.add_task("decode") if progress is not None else None
    if progress is not None:
        progress.start()
    start: float | None = None
    idents = _IdentColumns()
    text_of = decoder.text
    new = tuple.__new__  # Frame.trusted without the call: the reader checked the frames
    for block in read_log_columns(file):
        others = block.others
        for row, (timestamp, row_id, row_data, row_extended) in enumerate(zip(
                block.times, block.ids, block.data, block.extended, strict=True)):
            other = others.get(row) if others else None
            if other is None:
                can_id, data, extended = row_id, row_data, row_extended
                event = text_of(new(Frame, (can_id, data, extended)), timestamp)
            elif isinstance(other, UnreadableLine):
                unreadable.add(other)
                add(_unreadable_text(other, start, absolute))
                continue
            else:
                decoded = other_event(decoder, other)
                can_id, data, extended = decoded.frame
                event = str(decoded)
            if absolute:
                shown = iso_utc(timestamp)
            else:
                start = timestamp if start is None else start
                shown = f"{timestamp - start:12.6f}"
            add(f"{shown}  {idents[can_id, extended]}  {data.hex(' ').upper():<23}  {event}")
        if len(lines) >= _BATCH:
            output.write()
            if progress is not None and task is not None:
                progress.update(task, completed=output.written)


def _unreadable_text(line: UnreadableLine, start: float | None, absolute: bool) -> str:
    """The text output's line for a log line that is no frame: its time where it has one
    (and the clock has started), then what is wrong with it."""
    if line.time is not None and absolute:
        shown = iso_utc(line.time)
    elif line.time is not None and start is not None:
        shown = f"{line.time - start:12.6f}"
    else:
        shown = " " * (len(iso_utc(0.0)) if absolute else 12)
    return f"{shown}  {'?':>8}  {'':<23}  unreadable {line}"


#: lines written at once
_BATCH = 500
#: identifier columns kept (then they start over): a bus has a few hundred identifiers
_IDENTS_KEPT = 4096


class _IdentColumns(dict[tuple[int, bool], str]):
    """The text output's identifier column per (id, extended): 8 hex digits (29-bit) or 3
    (11-bit), right-aligned; kept, as a log has few identifiers (formatting one each line cost
    a tenth of the line)."""

    def __missing__(self, key: tuple[int, bool]) -> str:
        if len(self) >= _IDENTS_KEPT:
            self.clear()
        can_id, extended = key
        ident = f"{can_id:08X}" if extended else f"{can_id:03X}"
        column = self[key] = f"{ident:>8}"
        return column


def _write(lines: list[str]) -> None:
    """Write ``lines`` to stdout, each ended by a newline, and empty the list."""
    sys.stdout.write("\n".join(lines) + "\n")
    lines.clear()
