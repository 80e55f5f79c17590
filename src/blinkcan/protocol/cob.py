"""CiA 301 predefined connection set: the function code part of each COB-ID.

A COB-ID is function code + node id, e.g. the keypad's SDO replies on 580h + 15h = 595h.
"""

from __future__ import annotations

import math

NMT = 0x000
SYNC = 0x080
EMCY = 0x080
TPDO1 = 0x180
RPDO1 = 0x200
TPDO2 = 0x280
RPDO2 = 0x300
TPDO3 = 0x380
RPDO3 = 0x400
TPDO4 = 0x480
RPDO4 = 0x500
SDO_TX = 0x580  # server -> client (the device's replies)
SDO_RX = 0x600  # client -> server (requests to the device)
HEARTBEAT = 0x700  # boot-up and heartbeat (NMT error control)

NODE_ID_MIN = 1
NODE_ID_MAX = 0x7F


def check_range(what: str, value: int, low: int, high: int, hexadecimal: bool = False) -> int:
    """Return ``value`` if it is an int in low..high, else raise TypeError/ValueError naming
    the valid range (how every Python-side argument of blinkcan is checked)."""
    if isinstance(value, bool) or not isinstance(value, int):
        raise TypeError(f"{what} must be an int, not {type(value).__name__}")
    if not low <= value <= high:
        if hexadecimal:
            raise ValueError(f"{what} {value:#x} outside {low:#04x}..{high:#04x}")
        raise ValueError(f"{what} {value} outside {low}..{high}")
    return value


def check_time(what: str, value: float, minimum: float | None = None,
               infinite: bool = False) -> float:
    """Return ``value`` if it is a number of seconds, finite (or +inf where ``infinite``) and
    at least ``minimum``; else TypeError/ValueError (non-finite times are bad arguments)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise TypeError(f"{what} must be a number of seconds, not {type(value).__name__}")
    if not (math.isfinite(value) or (infinite and value == math.inf)):
        raise ValueError(f"{what} must be a finite number of seconds, not {value!r}")
    if minimum is not None and value < minimum:
        raise ValueError(f"{what} must be >= {minimum:g} seconds, not {value!r}")
    return value


def check_node_id(node_id: int) -> int:
    """Return ``node_id`` if it is a valid CANopen node id (1..127), else raise."""
    return check_range("node id", node_id, NODE_ID_MIN, NODE_ID_MAX, hexadecimal=True)


def split_cob_id(can_id: int) -> tuple[int, int]:
    """Split a standard COB-ID into (function code, node id)."""
    return can_id & 0x780, can_id & 0x7F
