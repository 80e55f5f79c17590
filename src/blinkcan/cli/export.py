"""``blinkcan export eds|dbc DEVICE [-o FILE]``: files for other tools, for any registered
model (the help lists them from the registry)."""

from __future__ import annotations

import click

from blinkcan.cli.bus_options import NODE_ID
from blinkcan.cli.control import J1939Address
from blinkcan.cli.targets import check_target, writing
from blinkcan.devices.keypad_j1939 import DEFAULT_ADDRESS
from blinkcan.devices.registry import describe_device, model_names, models
from blinkcan.formats.atomic import write_atomically
from blinkcan.formats.dbc import dbc_text
from blinkcan.formats.dbc_j1939 import dbc_text as j1939_dbc_text
from blinkcan.formats.eds import eds_text


@click.command("export", epilog=f"DEVICE: {model_names()}.")
@click.argument("kind", type=click.Choice(["eds", "dbc"]))
@click.argument("device", metavar="DEVICE")
@click.option("-o", "--output", type=click.Path(dir_okay=False), help="File (-, or none: stdout).")
@click.option("--quirks", type=click.Choice(["firmware", "cia301"]), default="firmware",
              show_default=True, help="EDS: the profile whose default values to write.")
@click.option("--node-id", type=NODE_ID, default=None,
              help="DBC: the node the COB-IDs are for (1..127).")
@click.option("--manual", default=None, help="Keypad generation (manual revision), e.g. 1.1.")
@click.option("--force", is_flag=True, help="Replace FILE if it exists.")
@click.option("--protocol", type=click.Choice(["canopen", "j1939"]), default="canopen",
              show_default=True, help="DBC of a keypad: its CANopen PDOs or its J1939 mode.")
@click.option("--address", type=J1939Address(), default=None,
              help="DBC, J1939: the keypad's source address (default 21h; --node-id says it "
                   "too).")
def command(kind: str, device: str, output: str | None, quirks: str, node_id: int | None,
            manual: str | None, force: bool, protocol: str, address: int | None) -> None:
    """Write the EDS or DBC file of a device, from the same tables the twins run on.

    \b
    blinkcan export dbc keypad --protocol j1939 -o keypad-j1939.dbc
    """
    if manual and "@" in device:
        raise click.UsageError(f"{device} names its generation and --manual {manual} another: "
                               "name it once")
    try:
        description = describe_device(f"{device}@{manual}" if manual else device, quirks)
    except ValueError as error:
        raise click.BadParameter(str(error), param_hint="DEVICE") from None
    if output == "-":  # as click's File and python-can's tools read it: standard output
        output = None
    if output is not None:
        check_target(output, force)
    if protocol == "j1939" or address is not None:
        if kind != "dbc" or "j1939" not in description.features:
            having = [m for m in models() if "j1939" in m.description().features]
            raise click.UsageError(
                "J1939 mode: a DBC of " + ", ".join(m.description().title for m in having)
                + "".join(f" (blinkcan export dbc {m.name} --protocol j1939)" for m in having))
        if node_id is not None:  # a J1939 keypad is at its address: --node-id says it too
            if address is not None and address != node_id:  # (as keypad and emulate take it)
                raise click.UsageError(f"a J1939 DBC is for one address: --node-id "
                                       f"{node_id:02X}h or --address {address:02X}h")
            address = node_id
        text = j1939_dbc_text(address if address is not None else DEFAULT_ADDRESS)
    else:
        text = eds_text(description) if kind == "eds" else dbc_text(description, node_id)
    if output is None:
        click.echo(text, nl=False)
    else:
        with writing(output):
            write_atomically(output, text.encode("utf-8"))
        click.echo(f"wrote {output}", err=True)

