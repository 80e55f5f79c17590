"""``blinkcan keypad ...`` and ``blinkcan keybox ...``: one-shot control and configuration on
top of the host drivers. Changing a node id or bit rate asks for confirmation (``--yes``).

Every command, PDO-only ones included (``keypad led``), first confirms which device answers at
the node id (the drivers' identity check): nothing answering, or another kind of device, is one
line and a non-zero exit, and the bus sees no command."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

import click

from blinkcan.cli.bus_options import bus_options, cli_bus, parse_int
from blinkcan.devices.registry import model
from blinkcan.host import IdentityError, Keybox, Keypad, SdoError


@contextmanager
def _device(kind: str, node_id: str | None, interface: str | None, channel: str | None,
            bitrate: int | None, start: bool = False) -> Iterator[Keypad | Keybox]:
    bus = cli_bus(interface, channel, bitrate)
    node = parse_int(node_id) if node_id else model(kind).default_node_id
    try:
        try:
            if kind == "keypad":
                device: Keypad | Keybox = Keypad(bus, node, start=start)
            else:
                device = Keybox(bus, node, start=start)
        except (IdentityError, SdoError) as error:
            raise click.ClickException(str(error)) from None
        try:
            yield device
        except (SdoError, ValueError) as error:
            raise click.ClickException(str(error)) from None
        finally:
            device.close()
    finally:
        bus.shutdown()


def _info(device: Keypad | Keybox) -> None:
    identity = device.identity()
    for name in ("node_id", "model", "model_id", "device_name", "hardware_version",
                 "software_version", "serial_number"):
        value = getattr(identity, name)
        if value is not None:
            click.echo(f"{name:<17} {value:02X}h" if name == "node_id" else f"{name:<17} {value}")
    click.echo(f"{'vendor_id':<17} {identity.vendor_id:08X}h")


def _confirm(what: str, yes: bool) -> None:
    if not yes and not click.confirm(f"{what} at the next reset of the device. Go on?"):
        raise click.Abort()


@click.group("keypad")
@click.option("--node-id", default=None, help="The keypad's node id (default 15h).")
@bus_options
@click.pass_context
def keypad(ctx: click.Context, node_id: str | None, interface: str | None, channel: str | None,
           bitrate: int | None) -> None:
    """One-shot control of a PKP-2600-SI keypad."""
    ctx.obj = ("keypad", node_id, interface, channel, bitrate)


@click.group("keybox")
@click.option("--node-id", default=None, help="The Keybox's node id (default 0Ch).")
@bus_options
@click.pass_context
def keybox(ctx: click.Context, node_id: str | None, interface: str | None, channel: str | None,
           bitrate: int | None) -> None:
    """One-shot control of a Keybox."""
    ctx.obj = ("keybox", node_id, interface, channel, bitrate)


for group in (keypad, keybox):
    @group.command("info")
    @click.pass_obj
    def info(obj: tuple[str, str | None, str | None, str | None, int | None]) -> None:
        """Identity: name, model, versions (un-reversed), serial, vendor."""
        with _device(*obj) as device:
            _info(device)

    @group.command("heartbeat")
    @click.argument("milliseconds", type=int)
    @click.pass_obj
    def heartbeat(obj: tuple[str, str | None, str | None, str | None, int | None],
                  milliseconds: int) -> None:
        """Producer heartbeat period in ms (0 = off)."""
        with _device(*obj) as device:
            device.set_heartbeat(milliseconds / 1000)

    @group.command("set-node-id")
    @click.argument("new_id")
    @click.option("--yes", is_flag=True, help="Do not ask.")
    @click.pass_obj
    def set_node_id(obj: tuple[str, str | None, str | None, str | None, int | None],
                    new_id: str, yes: bool) -> None:
        """Store a new node id (applies at the next reset)."""
        node = parse_int(new_id)
        _confirm(f"The {obj[0]} will move to node {node:02X}h", yes)
        with _device(*obj) as device:
            device.set_node_id(node, confirm=True)

    @group.command("set-baud")
    @click.argument("bitrate", type=int)
    @click.option("--yes", is_flag=True, help="Do not ask.")
    @click.pass_obj
    def set_baud(obj: tuple[str, str | None, str | None, str | None, int | None], bitrate: int,
                 yes: bool) -> None:
        """Store a bit rate in bit/s, with this model's own code (applies at the next reset)."""
        _confirm(f"The {obj[0]} will leave this bus for {bitrate} bit/s", yes)
        with _device(*obj) as device:
            device.set_bitrate(bitrate, confirm=True)


@keypad.command("led")
@click.argument("key", type=int)
@click.argument("colour")
@click.option("--blink", default=None, help="Blink colour (with COLOUR: alternate).")
@click.pass_obj
def led(obj: tuple[str, str | None, str | None, str | None, int | None], key: int, colour: str,
        blink: str | None) -> None:
    """Light KEY (1-12) in COLOUR (off, red, green, blue, amber, cyan, magenta, white). Starts
    the keypad; other keys go dark (a one-shot command knows no earlier picture)."""
    with _device(*obj, start=True) as device:
        assert isinstance(device, Keypad)
        device.set_led(key, colour, blink=blink)


@keypad.command("backlight")
@click.option("--colour", default=None, help="Backlight colour (red ... yellow/green).")
@click.option("--level", type=int, default=None, help="0-63 (0 = off).")
@click.pass_obj
def backlight(obj: tuple[str, str | None, str | None, str | None, int | None],
              colour: str | None, level: int | None) -> None:
    """Backlight colour and level."""
    with _device(*obj, start=True) as device:
        assert isinstance(device, Keypad)
        device.set_backlight(colour, level)


@keypad.command("brightness")
@click.argument("level", type=int)
@click.pass_obj
def brightness(obj: tuple[str, str | None, str | None, str | None, int | None],
               level: int) -> None:
    """Indicator LED brightness 0-63."""
    with _device(*obj, start=True) as device:
        assert isinstance(device, Keypad)
        device.set_brightness(level)


def _pin_command(name: str, action: str, doc: str) -> None:
    @keybox.command(name, help=doc)
    @click.argument("pin", type=int)
    @click.pass_obj
    def command(obj: tuple[str, str | None, str | None, str | None, int | None],
                pin: int) -> None:
        with _device(*obj) as device:
            getattr(device, action)(pin)


_pin_command("on", "on", "Output PIN (1-13) HIGH.")
_pin_command("off", "off", "Output PIN OFF.")
_pin_command("reset", "reset", "RESET output PIN out of FAULT.")


@keybox.command("states")
@click.pass_obj
def states(obj: tuple[str, str | None, str | None, str | None, int | None]) -> None:
    """Every output's state, and the input levels."""
    with _device(*obj) as device:
        assert isinstance(device, Keybox)
        outputs, inputs = device.states(), device.inputs()
        for pin in outputs:
            click.echo(f"pin {pin:>2}: {outputs[pin]:<5} input {'high' if inputs[pin] else 'low'}")


@keybox.command("faults")
@click.pass_obj
def faults(obj: tuple[str, str | None, str | None, str | None, int | None]) -> None:
    """The outputs in FAULT."""
    with _device(*obj) as device:
        assert isinstance(device, Keybox)
        found = [pin for pin, state in device.states().items() if state == "fault"]
        click.echo(", ".join(map(str, found)) if found else "no output in FAULT")
