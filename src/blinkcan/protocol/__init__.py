"""Pure CANopen (CiA 301): frames, NMT, SDO, heartbeat. No I/O, no clocks."""

from blinkcan.protocol.abort import AbortCode, describe_abort
from blinkcan.protocol.frame import Frame
from blinkcan.protocol.nmt import NmtCommand, NmtState, heartbeat_frame, nmt_frame, parse_nmt
from blinkcan.protocol.sdo_server import ObjectAccess, SdoServer

__all__ = [
    "AbortCode",
    "Frame",
    "NmtCommand",
    "NmtState",
    "ObjectAccess",
    "SdoServer",
    "describe_abort",
    "heartbeat_frame",
    "nmt_frame",
    "parse_nmt",
]
