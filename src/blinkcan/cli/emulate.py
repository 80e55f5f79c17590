"""``blinkcan emulate DEVICE[@GENERATION][/PROTOCOL][:NODE] ...``: run twins on a bus until
Ctrl-C; each device in the protocol it names (``keypad/j1939:0x21``), else ``--protocol``.

A frame from one of the twins' node ids that the emulator did not send (a boot-up, heartbeat or
SDO reply; for a keypad in J1939 mode, any frame from its source address) means another device
uses that id: every SDO request then gets two answers. It is said once per node id.

Each frame is a line: seconds since the emulator started (``--absolute``: the wall clock), the
direction, the frame and its meaning; off a terminal the lines are never wrapped."""

from __future__ import annotations

import contextlib
import signal
import threading
import time
from collections.abc import Iterator
from types import MappingProxyType
from typing import Any

import click
from rich.console import Console
from rich.markup import escape

from blinkcan.cli.bus_options import (
    NODE_ID,
    bus_options,
    bus_settings,
    cli_bus,
    describe_bus,
    parse_int,
    parse_node_id,
)
from blinkcan.cli.clock import ABSOLUTE, Clock
from blinkcan.cli.command_socket import command_socket
from blinkcan.cli.extras import install_command
from blinkcan.cli.render import output_console
from blinkcan.cli.seconds import Seconds
from blinkcan.cli.typed_commands import typed_commands
from blinkcan.decode import Decoder
from blinkcan.decode.j1939 import j1939_node
from blinkcan.decode.nodes import DeviceSpec, NodeKey
from blinkcan.devices.keypad_j1939 import DEFAULT_ADDRESS as J1939_DEFAULT_ADDRESS
from blinkcan.devices.keypad_j1939 import NVM_PREFIX
from blinkcan.devices.keypad_j1939 import command as j1939_command
from blinkcan.devices.model import Model
from blinkcan.devices.registry import model_names, models, parse_spec
from blinkcan.formats.nvm_file import nvm_file
from blinkcan.protocol.cob import HEARTBEAT, NODE_ID_MAX, SDO_RX, SDO_TX, split_cob_id
from blinkcan.protocol.frame import Frame
from blinkcan.runtime import Emulator
from blinkcan.twin.base import CanopenTwin
from blinkcan.twin.keypad import PROTOCOLS as TWIN_PROTOCOLS
from blinkcan.twin.keypad import KeypadTwin
from blinkcan.twin.nvm import NvmError
from blinkcan.twin.registry import build_twin

#: §16: the source addresses a keypad in J1939 mode can take (DEVICE:ADDR)
J1939_ADDRESSES = j1939_command("source_address").fields[0].valid


def _check_applies(option: str, given: bool, chosen: list[Model], having: list[Model]) -> None:
    """An option that applies to none of the devices asked for is a usage error naming the
    models it applies to (it would otherwise be silently ignored)."""
    if given and not chosen:
        names = ", ".join(m.description().title for m in having)
        raise click.UsageError(f"{option} applies to {names} only: none of the devices asked "
                               "for has it")


def device_protocols() -> tuple[str, ...]:
    """The protocols a device can run in: CANopen, every model's, and the modes the registry's
    models have besides (the PKP-2600-SI's J1939, spec/pkp-2600-si-j1939.md)."""
    modes = {f for m in models() for f in m.description().features} & set(TWIN_PROTOCOLS)
    return ("canopen", *sorted(modes - {"canopen"}))


def split_device(spec: str) -> tuple[str, str | None, str]:
    """DEVICE[@GEN][/PROTOCOL][:NODE] -> (DEVICE[@GEN], the protocol it names or None, NODE
    text): ``keypad@1.5/j1939:0x21``; a protocol no device runs is a usage error naming them."""
    model_text, _, node_text = spec.partition(":")
    model_text, slash, protocol = model_text.partition("/")
    if slash and protocol not in device_protocols():
        raise click.BadParameter(f"{spec!r}: protocol {protocol!r} is not one of "
                                 f"{', '.join(device_protocols())}", param_hint="DEVICE")
    return model_text, (protocol if slash else None), node_text


def build_twins(devices: tuple[str, ...], node_id: int | None, nvm: str | None,
                quirks: str, low_side: tuple[int, ...] = (),
                protocol: str = "canopen") -> list[CanopenTwin]:
    """The twins of DEVICE[@GEN][/PROTOCOL][:NODE]...: each in the protocol it names, or
    ``protocol`` (--protocol) where it has that mode; checked before any bus opens."""
    if nvm is not None and len(devices) != 1:
        raise click.UsageError("--nvm names one file, for one device")
    if node_id is not None and len(devices) != 1:
        raise click.UsageError("--node-id is for one device; write DEVICE:NODE for several")
    split = [split_device(spec) for spec in devices]
    try:
        chosen = [parse_spec(model_text)[0] for model_text, _, _ in split]
    except ValueError as error:
        raise click.BadParameter(str(error), param_hint="DEVICE") from None
    _check_applies("--low-side", bool(low_side),
                   [m for m in chosen if m.description().face.low_side_capable],
                   [m for m in models() if m.description().face.low_side_capable])
    # spec/pkp-2600-si-j1939.md: the PKP-2600-SI's J1939 mode; the other devices stay CANopen
    defaulted = [m for m, (_, named, _) in zip(chosen, split, strict=True) if named is None]
    _check_applies(f"--protocol {protocol}", protocol != "canopen" and bool(defaulted),
                   [m for m in defaulted if protocol in m.description().features],
                   [m for m in models() if protocol in m.description().features])
    for spec, found, (_, named, _) in zip(devices, chosen, split, strict=True):
        if named not in (None, "canopen") and named not in found.description().features:
            having = ", ".join(m.description().title for m in models()
                               if named in m.description().features)
            raise click.UsageError(f"{spec}: {found.description().title} has no {named} mode "
                                   f"({named}: {having} only)")
    twins: list[CanopenTwin] = []
    for (model, named, node_text), found in zip(split, chosen, strict=True):
        running = named if named is not None else protocol
        j1939 = running != "canopen" and running in found.description().features
        node = (_j1939_address(node_text) if j1939 else parse_node_id(node_text)) \
            if node_text else node_id
        options: dict[str, object] = {}
        if low_side and found.description().face.low_side_capable:
            options["low_side"] = low_side
        if j1939:
            options["protocol"] = running
            if node is not None:  # J1939: DEVICE:ADDR is the source address it claims (§16)
                options["settings"] = {NVM_PREFIX + "source_address": node}
                if node > NODE_ID_MAX:  # no CANopen node id: the model's default one
                    node = None
        try:
            # the file store is opened here, at the edge: the twin layer does no I/O
            store = None if nvm is None else nvm_file(nvm)
            twins.append(build_twin(model, node, quirks, store, **options))
        except (ValueError, TypeError) as error:
            for twin in twins:
                twin.close()
            raise click.ClickException(str(error)) from None
    _refuse_shared_node_ids(twins)
    return twins


def _j1939_address(text: str) -> int:
    """DEVICE:ADDR of a keypad in J1939 mode: its source address, 01h..FDh (§16)."""
    address = parse_int(text)
    if address not in J1939_ADDRESSES:
        raise click.BadParameter(f"J1939 address {address:#x} outside {J1939_ADDRESSES} (§16)",
                                 param_hint="DEVICE")
    return address


def _refuse_shared_node_ids(twins: list[CanopenTwin]) -> None:
    """Two devices on one node id answer every SDO request twice, two keypads at one J1939
    address each other's commands: refused."""
    seen: dict[tuple[bool, int], CanopenTwin] = {}
    for twin in twins:
        j1939 = isinstance(twin, KeypadTwin) and twin.protocol == "j1939"
        where = (True, twin.j1939.settings["source_address"]) \
            if isinstance(twin, KeypadTwin) and j1939 else \
            (False, twin.node_id)
        other = seen.setdefault(where, twin)
        if other is not twin:
            for each in twins:
                each.close()
            taken = {number for is_j1939, number in seen if is_j1939 == j1939}
            what = "J1939 address" if j1939 else "node"
            raise click.UsageError(
                f"{other.description.kind} and {twin.description.kind} both on {what} "
                f"{where[1]:02X}h; give each its own, e.g. {twin.description.kind}:"
                f"0x{_free_node_id(where[1], taken):02X}")


def decoder_devices(twins: list[CanopenTwin]) -> dict[NodeKey, DeviceSpec]:
    """What the emulator's decoder is told: each twin at its node id, and a keypad in J1939
    mode at its J1939 address too (so a command to it is read as one from the first frame)."""
    devices: dict[NodeKey, DeviceSpec] = {}
    for twin in twins:
        devices[twin.node_id] = twin.description
        if isinstance(twin, KeypadTwin) and twin.protocol == "j1939":
            devices[j1939_node(twin.j1939.settings["source_address"])] = twin.description
    return devices


def _free_node_id(near: int, taken: set[int]) -> int:
    candidate: int
    for candidate in [*range(near + 1, 128), *range(1, near)]:
        if candidate not in taken:
            return candidate
    return near


@click.command("emulate", epilog=f"DEVICE: {model_names()}.")
@click.argument("devices", nargs=-1, required=True, metavar="DEVICE[@GEN][/PROTOCOL][:NODE]...")
@click.option("--node-id", type=NODE_ID, default=None,
              help="Node id of a single device (0x15, 21, 15h).")
@click.option("--nvm", default=None, type=click.Path(dir_okay=False),
              help="JSON file keeping a single device's stored settings across runs.")
@click.option("--quirks", type=click.Choice(["firmware", "cia301"]), default="firmware",
              show_default=True,
              help="Reproduce the manuals' firmware quirks, or be CiA 301-clean.")
@click.option("--response-delay", type=Seconds(maximum=10.0), default=0.0,
              show_default=True,
              help="Seconds between a request and the reply (real keypads drop overlapping SDO).")
@click.option("--low-side", default="", metavar="PINS",
              help="Keybox pins built as low-side drivers, e.g. 2,5 (errata K22).")
@click.option("--web", is_flag=False, flag_value="127.0.0.1:8080", default=None,
              metavar="[HOST:PORT]", help="Serve the front panel (default 127.0.0.1:8080).")
@click.option("--protocol", type=click.Choice(device_protocols()), default="canopen",
              show_default=True,
              help="Devices that name no /PROTOCOL and have this one start in it unless --nvm "
                   "stored another (the others stay CANopen; J1939: source address "
                   f"{J1939_DEFAULT_ADDRESS:02X}h unless DEVICE:ADDR names one, 250 kbit/s).")
@click.option("-q", "--quiet", is_flag=True, help="Do not print the frames.")
@ABSOLUTE
@bus_options
def command(devices: tuple[str, ...], node_id: int | None, nvm: str | None, quirks: str,
            response_delay: float, low_side: str, web: str | None, protocol: str,
            quiet: bool, absolute: bool) -> None:
    """Run device twins on a CAN bus until Ctrl-C. DEVICE: a registered model or alias
    (keypad = pkp-2600-si, keybox, ...), optionally @GENERATION (keypad@1.5: the newer
    firmware, manual rev 1.5), optionally /PROTOCOL (keypad/j1939: in its J1939 mode; none
    named: --protocol). Commands typed on its input act on the devices as hands do
    (press 3, 16h turn 1 +5, 0Ch blow-fuse 4, keybox power-cycle; help lists them).

    \b
    blinkcan emulate keypad keybox
    blinkcan emulate keypad@1.5 keybox:0x0D --low-side 2,5
    blinkcan emulate keypad:0x15 keypad:0x16 -i socketcan -c vcan0
    blinkcan emulate keypad --protocol j1939
    blinkcan emulate keypad:0x15 keypad/j1939:0x21 keybox
    """
    console = output_console()
    web_address = None if web is None else panel_address(web)
    try:
        pins = tuple(parse_int(p) for p in low_side.split(",") if p.strip())
        twins = build_twins(devices, node_id, nvm, quirks, pins, protocol)
    except NvmError as error:
        raise click.ClickException(str(error)) from None
    bus = cli_bus()
    decoder = Decoder(decoder_devices(twins))
    # the emulator's clock is time.monotonic: its start is 0, its offset to the epoch measured
    clock = Clock(absolute, start=time.monotonic(), to_epoch=time.time() - time.monotonic())
    printer = None if quiet else _FramePrinter(console, decoder, clock)
    emulator = Emulator(bus, twins, response_delay=response_delay)
    foreign = ForeignFrames(emulator.twins, console)

    def on_frame(frame: Frame, sent: bool, now: float) -> None:
        if not sent:
            foreign(frame)
        if printer is not None:
            printer(frame, sent, now)

    emulator.on_frame = on_frame
    names = ", ".join(_name(t) for t in twins)
    console.print(f"[bold]blinkcan[/] emulating {names} on {describe_bus(bus_settings())}. "
                  "Ctrl-C stops.")
    try:
        with _stopped_as_by_ctrl_c(), emulator, panel(emulator, web_address, console), \
                typed_commands(emulator, console) as commands, command_socket(commands, console):
            never = threading.Event()
            while not never.wait(_SIGNALS_SEEN_WITHIN_S):
                pass  # (one endless wait may miss a signal that reached another thread)
    except KeyboardInterrupt:
        console.print("stopped")
    finally:
        bus.shutdown()


#: the main thread wakes this often, so that a stop signal always stops it
_SIGNALS_SEEN_WITHIN_S = 0.5


@contextlib.contextmanager
def _stopped_as_by_ctrl_c() -> Iterator[None]:
    """While the body runs, SIGTERM (``kill``, a service manager) and SIGHUP (its terminal
    closed) stop the emulator as Ctrl-C does: its command socket is removed and its bus shut
    down (their default ends the process on the spot, leaving the socket). A signal ignored
    when it started (``nohup``) stays ignored."""
    if threading.current_thread() is not threading.main_thread():  # signals reach only it
        yield
        return
    previous = {}
    for name in ("SIGTERM", "SIGHUP"):
        number = getattr(signal, name, None)
        if number is not None and signal.getsignal(number) is not signal.SIG_IGN:
            previous[number] = signal.signal(number, _interrupt)
    try:
        yield
    finally:
        for number, handler in previous.items():
            signal.signal(number, handler)


def _interrupt(signum: int, frame: object) -> None:
    raise KeyboardInterrupt


def _name(twin: CanopenTwin) -> str:
    """"PKP-2600-SI keypad 15h, generation 1 (manual rev 1.1)", "Keybox 0Ch, manual rev 1.0",
    "PKP-2600-SI keypad 21h (J1939), ...": the model's own title and edition."""
    description = twin.description
    where = f"{twin.node_id:02X}h"
    if isinstance(twin, KeypadTwin) and twin.protocol == "j1939":
        where = f"{twin.j1939.settings['source_address']:02X}h (J1939)"
    return f"{description.title} {where}, {description.edition}"


def panel_address(text: str) -> tuple[str, int]:
    """--web's HOST:PORT, checked before the bus opens (and the web extra with it)."""
    try:
        from blinkcan.web.server import parse_address  # noqa: PLC0415 optional extra
    except ImportError:
        raise click.ClickException("the front panel needs the web extra: "
                                   f"{install_command('web')}") from None
    try:
        return parse_address(text)
    except ValueError as error:
        raise click.BadParameter(str(error), param_hint="'--web'") from None


@contextlib.contextmanager
def panel(emulator: Emulator, address: tuple[str, int] | None,
          console: Console) -> Iterator[None]:
    """Serve the front panel beside ``emulator`` when an address is given."""
    if address is None:
        yield
        return
    from blinkcan.web.server import PanelServer  # noqa: PLC0415 optional extra (checked)

    try:
        server = PanelServer(emulator, *address).start()
    except OSError as error:
        raise click.ClickException(f"front panel: {error}") from None
    console.print(f"front panel: {server.url}")
    try:
        yield
    finally:
        server.stop()


#: what only the device at a node id sends: boot-up and heartbeat, SDO replies (CiA 301)
_FROM_NODE = MappingProxyType({HEARTBEAT: "heartbeat", SDO_TX: "SDO reply"})


class ForeignFrames:
    """Warns, once per node id or J1939 address, when a frame comes from an id one of
    ``twins`` uses that the emulator did not send (a bus never hears its own frames)."""

    def __init__(self, twins: list[CanopenTwin], console: Console) -> None:
        self.twins = twins
        self.console = console
        self.warned: set[tuple[bool, int]] = set()  # (J1939, node id or address)

    def __call__(self, frame: Frame) -> None:
        if frame.extended:
            self._j1939(frame)
            return
        function, node = split_cob_id(frame.can_id)
        what = _FROM_NODE.get(function)
        if what is None or (False, node) in self.warned or not any(
                twin.node_id == node and SDO_RX + node in twin.listening for twin in self.twins):
            return
        self.warned.add((False, node))
        if function == HEARTBEAT and frame.data[:1] == b"\x00":
            what = "boot-up"
        self.console.print(
            f"[yellow]warning:[/] another device uses node {node:02X}h (heard a {what} on "
            f"{frame.can_id:03X}h that this emulator did not send): two devices at one node id "
            "answer every SDO request twice; give each its own node id")

    def _j1939(self, frame: Frame) -> None:
        address = frame.can_id & 0xFF  # J1939-21: the source address is the identifier's low byte
        if (True, address) in self.warned or not any(
                isinstance(twin, KeypadTwin) and twin.protocol == "j1939"
                and twin.j1939.address == address for twin in self.twins):
            return
        self.warned.add((True, address))
        self.console.print(
            f"[yellow]warning:[/] another device uses J1939 address {address:02X}h (heard "
            f"{frame.can_id:08X}h, which this emulator did not send); give each its own "
            "address (address claim, 74h, moves one of them)")


class _FramePrinter:
    def __init__(self, console: Console, decoder: Decoder, clock: Clock) -> None:
        self.console = console
        self.decoder = decoder
        self.clock = clock

    def __call__(self, frame: Frame, sent: bool, now: float) -> Any:
        arrow = "[cyan]->[/]" if sent else "[yellow]<-[/]"
        self.console.print(f"{self.clock(now):>10} {arrow} {frame.can_id:03X} "
                           f"{frame.data.hex(' ').upper():<24} "
                           f"{escape(str(self.decoder.decode(frame, now)))}")
