"""DBC files for the devices' PDOs and heartbeats, built with cantools from the PDO layouts.

A mask of keys, LEDs or pins becomes one 1-bit signal per item ("red_7", "key_4", "fault_9"),
so cantools decodes a frame to what it means. One DBC holds the messages of one node.
"""

from __future__ import annotations

import os
from collections import OrderedDict

import cantools.database as cdb
from cantools.database.can import Message, Signal
from cantools.database.namedsignalvalue import NamedSignalValue

from blinkcan.devices.model import DeviceDescription
from blinkcan.devices.pdo import Direction, PdoSignal
from blinkcan.formats.atomic import write_atomically
from blinkcan.protocol.cob import HEARTBEAT
from blinkcan.protocol.nmt import NmtState

_STATES = {NmtState.BOOT_UP: "boot_up", NmtState.STOPPED: "stopped",
           NmtState.OPERATIONAL: "operational", NmtState.PRE_OPERATIONAL: "pre_operational"}


#: the sign bit of a sign-magnitude signal as cantools names its values
_ROTATION: OrderedDict[int, str | NamedSignalValue] = OrderedDict(
    ((0, "clockwise"), (1, "counterclockwise")))


def _signals(signal: PdoSignal, receiver: list[str]) -> list[Signal]:
    if signal.sign_magnitude:
        # a DBC signal is two's complement or unsigned: the magnitude and the sign bit as two
        # signals, so cantools reads "81h" as 1 tick counterclockwise, not 129 (MT §12/§13:
        # X = 1 counterclockwise, YYYYYYY = number of ticks)
        sign = signal.start + signal.length - 1
        return [Signal(signal.name, signal.start, signal.length - 1,
                       byte_order="little_endian", is_signed=False,
                       comment=f"{signal.label} (magnitude)", receivers=receiver),
                Signal(f"{signal.name}_counterclockwise", sign, 1, byte_order="little_endian",
                       is_signed=False,
                       conversion=cdb.conversion.NamedSignalConversion(1, 0, _ROTATION,
                                                                       is_float=False),
                       comment=f"{signal.label}: the sign", receivers=receiver)]
    if signal.item is None:  # a value, scaled to its unit where the layout gives one
        conversion = cdb.conversion.BaseConversion.factory(
            scale=signal.scale, offset=0, is_float=False)
        return [Signal(signal.name, signal.start, signal.length, byte_order="little_endian",
                       is_signed=False, conversion=conversion, unit=signal.unit or None,
                       comment=signal.label, receivers=receiver)]
    return [Signal(f"{signal.name}_{i + 1}", signal.start + i, 1, byte_order="little_endian",
                   is_signed=False, comment=f"{signal.label}: {signal.item} {i + 1}",
                   receivers=receiver)
            for i in range(signal.items or signal.length)]


def database(description: DeviceDescription, node_id: int | None = None) -> cdb.Database:
    node = node_id if node_id is not None else description.default_node_id
    prefix = f"{description.kind.upper()}_{node:02X}"
    messages = []
    for layout in description.pdos:
        to_device = layout.direction is Direction.RX
        senders = ["CONTROLLER"] if to_device else [prefix]
        receivers = [prefix] if to_device else ["CONTROLLER"]
        signals = [s for signal in layout.signals for s in _signals(signal, receivers)]
        messages.append(Message(layout.cob_id(node), f"{prefix}_{layout.name.upper()}",
                                layout.length, signals, comment=layout.label, senders=senders))
    state = Signal("state", 0, 8, byte_order="little_endian", is_signed=False,
                   conversion=cdb.conversion.NamedSignalConversion(
                       1, 0, OrderedDict((int(code), name) for code, name in _STATES.items()),
                       is_float=False),
                   receivers=["CONTROLLER"])
    messages.append(Message(HEARTBEAT + node, f"{prefix}_HEARTBEAT", 1, [state],
                            comment="Boot-up (00h) and heartbeat with NMT state",
                            senders=[prefix]))
    return cdb.Database(messages=messages, nodes=[cdb.can.Node(prefix), cdb.can.Node("CONTROLLER")])


def dbc_text(description: DeviceDescription, node_id: int | None = None) -> str:
    return str(database(description, node_id).as_dbc_string())


def write_dbc(description: DeviceDescription, path: str | os.PathLike[str],
              node_id: int | None = None) -> None:
    write_atomically(path, dbc_text(description, node_id).encode("utf-8"))
