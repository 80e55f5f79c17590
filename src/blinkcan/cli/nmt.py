"""``blinkcan nmt start|stop|pre-operational|reset|reset-communication NODE``: the CiA 301
network management commands, to one node or to all (NODE ``all`` or 0).

NMT has no acknowledge; after sending, the command listens for ``--listen`` seconds and prints
the boot-ups and heartbeats it hears from the node(s), which say what the node did (a node with
its heartbeat off stays silent, except for the boot-up after a reset). Only what a node says
after the command counts: what the bus received before it is dropped unread, and a frame
stamped before the command was sent is no answer to it (a heartbeat sent a few ms earlier
would otherwise report the state the command changed).
"""

from __future__ import annotations

import time

import can
import click

from blinkcan.cli.bus_options import bus_options, cli_bus, parse_node_id
from blinkcan.cli.seconds import Seconds
from blinkcan.cli.whole import NegativeArguments
from blinkcan.formats.frame_check import wrong_type
from blinkcan.protocol.cob import HEARTBEAT, split_cob_id
from blinkcan.protocol.nmt import NmtCommand, NmtState, nmt_frame
from blinkcan.runtime import to_frame, to_message
from blinkcan.runtime.canbus import is_undecodable
from blinkcan.twin.base import NMT_STATE_NAMES

#: seconds apart beyond which a frame's timestamp is taken to come from another clock
_SAME_CLOCK = 3600.0

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
    try:
        return parse_node_id(text)
    except click.BadParameter as error:
        raise click.BadParameter(f"{error.message}, or all", param_hint="NODE") from None


@click.group("nmt")
@bus_options
def command() -> None:
    """NMT commands (CiA 301) to a node, or to all of them with NODE = all."""


command.command_class = NegativeArguments  # ``nmt start -1``: a NODE out of range


def _nmt_command(name: str, code: NmtCommand, words: str) -> None:
    @command.command(name, help=f"NMT {words} to NODE (1..127, or all).")
    @click.argument("node")
    @click.option("--listen", type=Seconds(maximum=3600.0), default=0.5, show_default=True,
                  help="Seconds to listen for the node's boot-up and heartbeat afterwards.")
    @bus_options
    def send(node: str, listen: float) -> None:
        target = parse_target(node)
        bus = cli_bus()
        try:
            _drain(bus)
            sent_at = time.time()
            bus.send(to_message(nmt_frame(code, target), sent_at))
            who = "every node" if target == 0 else f"node {target:02X}h"
            click.echo(f"sent NMT {words} to {who}")
            _report(bus, target, listen, sent_at)
        finally:
            bus.shutdown()


def _drain(bus: can.BusABC, limit: int = 10_000) -> None:
    """Drop what the bus received before the command (at most ``limit`` frames)."""
    for _ in range(limit):
        try:
            if bus.recv(0) is None:
                return
        except can.CanError as error:
            if not is_undecodable(error):
                raise


def _receive(bus: can.BusABC, timeout: float) -> can.Message | None:
    """The next frame, or None; a frame the bus cannot decode, or a message that is no frame
    (:func:`~blinkcan.formats.frame_check.wrong_type`), is none of the nodes' answers."""
    try:
        message = bus.recv(timeout)
    except can.CanError as error:
        if is_undecodable(error):
            return None
        raise
    return None if message is None or wrong_type(message) is not None else message


def _said_after(message: can.Message, sent_at: float) -> bool:
    """Whether ``message`` was stamped after ``sent_at`` (``time.time()``). Buses stamp frames
    with the wall clock (python-can's socketcan, virtual, udp_multicast); an adapter that
    counts from its own start cannot be compared, and the drain before the command orders
    its frames instead."""
    if abs(message.timestamp - sent_at) > _SAME_CLOCK:
        return True
    return message.timestamp >= sent_at


def _report(bus: can.BusABC, target: int, listen: float, sent_at: float) -> None:
    """Print each node's first boot-up or heartbeat heard within ``listen`` seconds after the
    command went out at ``sent_at``."""
    heard: dict[int, str] = {}
    end = time.monotonic() + listen
    while (remaining := end - time.monotonic()) > 0:
        message = _receive(bus, min(remaining, 0.1))
        if message is None or not _said_after(message, sent_at):
            continue
        frame = to_frame(message)
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
