"""``blinkcan nmt start|stop|pre-operational|reset|reset-communication NODE``: the CiA 301
network management commands, to one node or to all (NODE ``all`` or 0).

NMT has no acknowledge; after sending, the command listens for ``--listen`` seconds and prints
the boot-ups and heartbeats it hears from the node(s), which say what the node did (a node with
its heartbeat off stays silent, except for the boot-up after a reset).
"""

from __future__ import annotations

import time

import can
import click

from blinkcan.cli.bus_options import bus_options, cli_bus, parse_node_id
from blinkcan.protocol.cob import HEARTBEAT, split_cob_id
from blinkcan.protocol.nmt import NmtCommand, NmtState, nmt_frame
from blinkcan.runtime import to_frame, to_message
from blinkcan.twin.base import NMT_STATE_NAMES

COMMANDS = {
    "start": (NmtCommand.START, "start"),
    "stop": (NmtCommand.STOP, "stop"),
    "pre-operational": (NmtCommand.ENTER_PRE_OPERATIONAL, "enter pre-operational"),
    "reset": (NmtCommand.RESET_NODE, "reset node"),
    "reset-communication": (NmtCommand.RESET_COMMUNICATION, "reset communication"),
}


def parse_target(text: str) -> int:
    """A node id 1..127, or 0 / ``all`` for every node (broadcast)."""
    if text.strip().lower() in ("all", "0", "0x0", "0x00", "00h", "0h"):
        return 0
    return parse_node_id(text)


@click.group("nmt")
@bus_options
def command() -> None:
    """NMT commands (CiA 301) to a node, or to all of them with NODE = all."""


def _nmt_command(name: str, code: NmtCommand, words: str) -> None:
    @command.command(name, help=f"NMT {words} to NODE (1..127, or all).")
    @click.argument("node")
    @click.option("--listen", type=click.FloatRange(min=0.0), default=0.5, show_default=True,
                  help="Seconds to listen for the node's boot-up and heartbeat afterwards.")
    @bus_options
    def send(node: str, listen: float) -> None:
        target = parse_target(node)
        bus = cli_bus()
        try:
            bus.send(to_message(nmt_frame(code, target)))
            who = "every node" if target == 0 else f"node {target:02X}h"
            click.echo(f"sent NMT {words} to {who}")
            _report(bus, target, listen)
        finally:
            bus.shutdown()


def _report(bus: can.BusABC, target: int, listen: float) -> None:
    """Print each node's first boot-up or heartbeat heard within ``listen`` seconds."""
    heard: dict[int, str] = {}
    end = time.monotonic() + listen
    while (remaining := end - time.monotonic()) > 0:
        message = bus.recv(min(remaining, 0.1))
        frame = to_frame(message) if message is not None else None
        if frame is None or len(frame.data) != 1 or frame.extended:
            continue
        function, node = split_cob_id(frame.can_id)
        if function != HEARTBEAT or node in heard or target not in (0, node):
            continue
        try:
            state = NmtState(frame.data[0] & 0x7F)
        except ValueError:
            continue
        heard[node] = "boot-up" if state is NmtState.BOOT_UP else NMT_STATE_NAMES[state]
        click.echo(f"node {node:02X}h: {heard[node]}")
    if not heard and listen:
        click.echo(f"no boot-up or heartbeat heard within {listen:g} s "
                   "(a node's heartbeat may be off)")


for _name, (_code, _words) in COMMANDS.items():
    _nmt_command(_name, _code, _words)
