"""``blinkcan scan``: the Blink devices on a bus."""

from __future__ import annotations

import click
from rich.console import Console
from rich.table import Table

from blinkcan.cli.bus_options import bus_options, bus_settings, cli_bus, describe_bus
from blinkcan.cli.seconds import Seconds
from blinkcan.host import scan, scan_j1939
from blinkcan.host.j1939_keypad import j1939_models


@click.command("scan")
@click.option("--listen", type=Seconds(maximum=3600.0), default=0.5, show_default=True,
              help="Seconds to listen for boot-ups and heartbeats first.")
@bus_options
def command(listen: float) -> None:
    """Find devices: boot-up and heartbeat heard, SDO read of 1000h, 1018h, 100Bh; keypads in
    J1939 mode by a software revision request and a request for address claimed, to all."""
    bus = cli_bus()
    try:
        found = scan(bus, listen=listen)
        j1939 = scan_j1939(bus, listen=max(listen, 0.2))
    finally:
        bus.shutdown()
    if not found and not j1939:
        raise click.ClickException(f"no device answered on {describe_bus(bus_settings())}")
    # model: the registered model (what --model takes), from its description, whichever
    # protocol the device speaks; a device no registered model describes shows its 100Bh
    table = Table("node", "device", "model", "firmware", "hardware", "device type", "heard")
    shared = []
    for device in found:
        if device.shared:  # each SDO request got a reply from each: no identity to show
            shared.append(device.describe_shared())
            table.add_row(f"{device.node_id:02X}h", f"[red]{device.answers} devices[/]", "",
                          "", "", f"{device.device_type:08X}h", "yes" if device.heard else "")
            continue
        table.add_row(f"{device.node_id:02X}h", device.kind or "other CANopen",
                      device.model or device.model_id or "", device.software_version or "",
                      device.hardware_version or "", f"{device.device_type:08X}h",
                      "yes" if device.heard else "")
    for keypad in j1939:  # "node" is the J1939 source address
        kind = "keypad (J1939)"
        if keypad.answers > 1:
            shared.append(f"{keypad.answers} keypads answer at J1939 address "
                          f"{keypad.address:02X}h: give each its own address")
            kind = f"[red]{keypad.answers} keypads (J1939)[/]"
        model = keypad.model or " or ".join(j1939_models())  # J1939 tells no model id
        table.add_row(f"{keypad.address:02X}h", kind, model, keypad.software_revision
                      or "", "", "", "claimed" if keypad.name else "")
    Console().print(table)
    if shared:  # a wiring mistake: the table is shown, the exit says something is wrong
        raise click.ClickException("; ".join(shared))
