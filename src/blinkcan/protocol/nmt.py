"""NMT slave: states, commands, and the state machine as a transition table (CiA 301 §7.3.2).

Both manuals (PKP §4-§8, KBX §11-§15) use the CiA 301 frames: COB-ID 000h, byte 0 the command,
byte 1 the node id (00h = all nodes). Resets are not states here: the twin performs them and
re-enters pre-operational through the boot-up, as CiA 301 describes.
"""

from __future__ import annotations

from enum import IntEnum
from typing import NamedTuple

from blinkcan.protocol.cob import HEARTBEAT, NMT
from blinkcan.protocol.frame import Frame


class NmtState(IntEnum):
    """The state byte of a heartbeat frame (PKP §25, KBX §16)."""

    BOOT_UP = 0x00
    STOPPED = 0x04
    OPERATIONAL = 0x05
    PRE_OPERATIONAL = 0x7F


class NmtCommand(IntEnum):
    """Byte 0 of an NMT frame (PKP §4-§7, KBX §11-§14)."""

    START = 0x01
    STOP = 0x02
    ENTER_PRE_OPERATIONAL = 0x80
    RESET_NODE = 0x81
    RESET_COMMUNICATION = 0x82


class NmtAction(IntEnum):
    """What a command asks of the node besides a state change."""

    NONE = 0
    RESET_NODE = 1
    RESET_COMMUNICATION = 2


#: (state, command) -> (next state, action). States the table omits do not change.
TRANSITIONS: dict[tuple[NmtState, NmtCommand], tuple[NmtState, NmtAction]] = {}
for _state in (NmtState.PRE_OPERATIONAL, NmtState.OPERATIONAL, NmtState.STOPPED):
    TRANSITIONS[_state, NmtCommand.START] = (NmtState.OPERATIONAL, NmtAction.NONE)
    TRANSITIONS[_state, NmtCommand.STOP] = (NmtState.STOPPED, NmtAction.NONE)
    TRANSITIONS[_state, NmtCommand.ENTER_PRE_OPERATIONAL] = (
        NmtState.PRE_OPERATIONAL,
        NmtAction.NONE,
    )
    TRANSITIONS[_state, NmtCommand.RESET_NODE] = (NmtState.BOOT_UP, NmtAction.RESET_NODE)
    TRANSITIONS[_state, NmtCommand.RESET_COMMUNICATION] = (
        NmtState.BOOT_UP,
        NmtAction.RESET_COMMUNICATION,
    )
del _state

#: Which services a state allows (CiA 301 table 84): SDO and PDO are off while stopped,
#: PDOs run only while operational.
SDO_ALLOWED = frozenset({NmtState.PRE_OPERATIONAL, NmtState.OPERATIONAL})
PDO_ALLOWED = frozenset({NmtState.OPERATIONAL})


class NmtRequest(NamedTuple):
    command: NmtCommand
    node_id: int  # 0 = every node


def parse_nmt(frame: Frame, aliases: dict[int, NmtCommand] | None = None) -> NmtRequest | None:
    """Decode an NMT frame, or None if it is not one.

    errata B4: DLC 2 per CiA 301; DLC 3..8 with trailing bytes accepted. ``aliases`` maps extra
    command bytes a device understands (the keypad's legacy 00h = stop, PKP §7 / errata P12).
    """
    data = frame.data
    if frame.can_id != NMT or frame.extended or len(data) < 2:
        return None
    code = data[0]
    try:
        command = NmtCommand(code)
    except ValueError:
        if aliases is None or code not in aliases:
            return None
        command = aliases[code]
    return NmtRequest(command, data[1])


def nmt_frame(command: NmtCommand | int, node_id: int) -> Frame:
    """The two-byte NMT frame a master sends."""
    return Frame(NMT, bytes((int(command), node_id)))


def heartbeat_frame(node_id: int, state: NmtState) -> Frame:
    """Boot-up (state 00h) or heartbeat frame, 700h + node id, one byte."""
    return Frame(HEARTBEAT + node_id, bytes((state,)))
