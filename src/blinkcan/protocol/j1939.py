"""J1939 basics, pure: 29-bit identifiers (SAE J1939-21) and the address-claim NAME and
procedure (SAE J1939-81). No I/O, no clock: time comes in as ``now``.

Why not a PyPI stack: ``can-j1939`` (2.0.12, the maintained fork of python-can-j1939) and the
older ``j1939`` (0.1.0.dev1, 2018) are I/O stacks. ``import j1939`` imports python-can and
``threading`` (its package ``__init__`` loads ``ElectronicControlUnit``, which owns a bus
notifier, a job thread and ``time.time()`` timers), so the pure core, which must import without
python-can and takes time as an argument, cannot use them; their address claim runs on that
thread and their identifier arithmetic is a few shifts. ``can-j1939`` is the reference instead:
the tests check these functions against its ``MessageId``, ``ParameterGroupNumber`` and
``Name``, and a keypad twin against its ``ControllerApplication`` claiming on a bus.

Identifier (J1939-21 §5.1): priority (3 bits) | reserved, data page | PDU format (PF) | PDU
specific (PS) | source address. PF < F0h is PDU1: PS is the destination address and the PGN
carries PS = 00h. PF >= F0h is PDU2: PS is a group extension and the message is broadcast.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from enum import Enum
from typing import NamedTuple

from blinkcan.protocol.frame import Frame

GLOBAL_ADDRESS = 0xFF  # J1939-21: destination "all nodes"
NULL_ADDRESS = 0xFE  # J1939-81: the source address of "cannot claim"
ADDRESS_MAX = 0xFD  # 00h-FDh are node addresses
PGN_REQUEST = 0xEA00  # J1939-21 §5.4.2
PGN_ADDRESS_CLAIMED = 0xEE00  # J1939-81 §4.2.2
PGN_PROPRIETARY_A = 0xEF00  # J1939-21 §5.4.6
PDU2_FORMAT_MIN = 0xF0
PGN_MAX = 0x3FFFF
DEFAULT_PRIORITY = 6
CLAIM_TIMEOUT_S = 0.25  # J1939-81 §4.4.2.2: 250 ms without a contending claim


class J1939Id(NamedTuple):
    """A parsed 29-bit identifier; ``destination`` is FFh for PDU2 (broadcast) PGNs."""

    priority: int
    pgn: int
    source: int
    destination: int


def is_pdu1(pgn: int) -> bool:
    """PF < F0h: the PS byte is a destination address (J1939-21 §5.2.4)."""
    return (pgn >> 8) & 0xFF < PDU2_FORMAT_MIN


def _check(name: str, value: int, high: int) -> int:
    if not isinstance(value, int) or isinstance(value, bool):
        raise TypeError(f"{name} must be an int, not {type(value).__name__}")
    if not 0 <= value <= high:
        raise ValueError(f"{name} must be 0..{high:#x}, not {value:#x}")
    return value


def compose_id(pgn: int, source: int, destination: int = GLOBAL_ADDRESS,
               priority: int = DEFAULT_PRIORITY) -> int:
    """The 29-bit identifier of a message; ``destination`` only for PDU1 PGNs."""
    _check("pgn", pgn, PGN_MAX)
    _check("source address", source, 0xFF)
    _check("destination address", destination, 0xFF)
    _check("priority", priority, 7)
    if is_pdu1(pgn):
        if pgn & 0xFF:
            raise ValueError(f"PDU1 PGN {pgn:#x} must end in 00h (its PS is the destination)")
        pgn |= destination
    elif destination != GLOBAL_ADDRESS:
        raise ValueError(f"PGN {pgn:#x} is PDU2 (broadcast): it has no destination address")
    return priority << 26 | pgn << 8 | source


def parse_id(can_id: int) -> J1939Id:
    """Priority, PGN (PS = 00h for PDU1), source and destination of a 29-bit identifier."""
    if not 0 <= can_id <= 0x1FFFFFFF:
        raise ValueError(f"29-bit identifier must be 0..0x1fffffff, not {can_id:#x}")
    pgn = (can_id >> 8) & PGN_MAX
    if is_pdu1(pgn):
        return J1939Id(can_id >> 26, pgn & ~0xFF, can_id & 0xFF, pgn & 0xFF)
    return J1939Id(can_id >> 26, pgn, can_id & 0xFF, GLOBAL_ADDRESS)


def j1939_frame(pgn: int, source: int, data: bytes, destination: int = GLOBAL_ADDRESS,
                priority: int = DEFAULT_PRIORITY) -> Frame:
    return Frame(compose_id(pgn, source, destination, priority), data, extended=True)


# -- NAME (J1939-81 §4.1.1) -------------------------------------------------------------------

#: (field, bit position, width), least significant first, as J1939-81 table 1 lays them out.
NAME_FIELDS: tuple[tuple[str, int, int], ...] = (
    ("identity_number", 0, 21),
    ("manufacturer_code", 21, 11),
    ("ecu_instance", 32, 3),
    ("function_instance", 35, 5),
    ("function", 40, 8),
    ("reserved", 48, 1),
    ("vehicle_system", 49, 7),
    ("vehicle_system_instance", 56, 4),
    ("industry_group", 60, 3),
    ("arbitrary_address_capable", 63, 1),
)


@dataclass(frozen=True, order=True)
class J1939Name:
    """The 64-bit NAME a node claims an address with; the lower value wins a conflict."""

    value: int

    def __post_init__(self) -> None:
        _check("NAME", self.value, (1 << 64) - 1)

    @classmethod
    def from_bytes(cls, data: bytes) -> J1939Name:
        """The 8 data bytes of an address claim, least significant byte first."""
        if len(data) != 8:
            raise ValueError(f"a J1939 NAME is 8 bytes, got {len(data)}")
        return cls(int.from_bytes(data, "little"))

    @classmethod
    def from_fields(cls, **fields: int) -> J1939Name:
        value = 0
        layout = {name: (shift, width) for name, shift, width in NAME_FIELDS}
        for name, field_value in fields.items():
            if name not in layout:
                raise ValueError(f"unknown NAME field {name!r}; fields: "
                                 f"{', '.join(layout)}")
            shift, width = layout[name]
            value |= _check(name, field_value, (1 << width) - 1) << shift
        return cls(value)

    def to_bytes(self) -> bytes:
        return self.value.to_bytes(8, "little")

    def field(self, name: str) -> int:
        for field_name, shift, width in NAME_FIELDS:
            if field_name == name:
                return (self.value >> shift) & ((1 << width) - 1)
        raise ValueError(f"unknown NAME field {name!r}")

    @property
    def arbitrary_address_capable(self) -> bool:
        return bool(self.value >> 63)

    def fields(self) -> dict[str, int]:
        return {name: self.field(name) for name, _, _ in NAME_FIELDS}


# -- address claim (J1939-81 §4.4) -------------------------------------------------------------


class ClaimState(Enum):
    IDLE = "idle"
    CLAIMING = "claiming"  # claim sent, waiting 250 ms for a contender
    CLAIMED = "claimed"
    CANNOT_CLAIM = "cannot claim"


def address_claim_frame(name: J1939Name, source: int) -> Frame:
    """Address Claimed (or, from FEh, Cannot Claim): the NAME to the global address."""
    return j1939_frame(PGN_ADDRESS_CLAIMED, source, name.to_bytes())


def request_frame(pgn: int, source: int, destination: int = GLOBAL_ADDRESS) -> Frame:
    """A Request (PGN EA00h) for ``pgn``: three data bytes, least significant first."""
    return j1939_frame(PGN_REQUEST, source, pgn.to_bytes(3, "little"), destination)


def next_address(current: int, taken: Iterable[int], first: int = 1,
                 last: int = ADDRESS_MAX) -> int | None:
    """The next address after ``current`` upwards, wrapping from ``last`` to ``first``, that
    is not ``taken``; None when every one is (spec J-5)."""
    blocked = set(taken)
    span = last - first + 1
    for step in range(1, span + 1):
        candidate = first + (current - first + step) % span
        if candidate not in blocked:
            return candidate
    return None


class AddressClaimer:
    """One node's side of the address-claim procedure, as a pure state machine.

    ``start`` sends the claim; a claim of the same address by a lower NAME makes this node move
    to the next free address upwards (arbitrary-address capable) or give up with "cannot claim"
    from FEh; a higher NAME is answered by repeating the claim. A Request for Address Claimed
    to the global or this node's address is answered with the claim (J1939-81 §4.4.3).
    """

    def __init__(self, name: J1939Name, preferred: int) -> None:
        self.name = name
        self.preferred = _check("preferred address", preferred, ADDRESS_MAX)
        self.state = ClaimState.IDLE
        self.address = preferred
        self.deadline: float | None = None
        self._taken: set[int] = set()

    @property
    def active(self) -> bool:
        """Whether this node may send from ``address``."""
        return self.state in (ClaimState.CLAIMING, ClaimState.CLAIMED)

    def start(self, now: float, address: int | None = None) -> list[Frame]:
        if address is not None:
            self.preferred = _check("address", address, ADDRESS_MAX)
        self.address = self.preferred
        self._taken = set()
        return self._claim(now)

    def _claim(self, now: float) -> list[Frame]:
        self.state = ClaimState.CLAIMING
        self.deadline = now + CLAIM_TIMEOUT_S
        return [address_claim_frame(self.name, self.address)]

    def advance(self, now: float) -> None:
        if self.state is ClaimState.CLAIMING and self.deadline is not None and now >= self.deadline:
            self.state = ClaimState.CLAIMED
            self.deadline = None

    def receive(self, frame: Frame, now: float) -> list[Frame]:
        """React to an Address Claimed or a Request for it; other frames: []."""
        if not frame.extended or self.state is ClaimState.IDLE:
            return []
        ident = parse_id(frame.can_id)
        if ident.pgn == PGN_REQUEST:
            return self._on_request(ident, frame.data)
        if ident.pgn == PGN_ADDRESS_CLAIMED and len(frame.data) == 8:
            return self._on_claim(ident.source, J1939Name.from_bytes(frame.data), now)
        return []

    def _on_request(self, ident: J1939Id, data: bytes) -> list[Frame]:
        if len(data) < 3 or int.from_bytes(data[:3], "little") != PGN_ADDRESS_CLAIMED:
            return []
        if self.state is ClaimState.CANNOT_CLAIM:
            return [address_claim_frame(self.name, NULL_ADDRESS)]
        if ident.destination not in (GLOBAL_ADDRESS, self.address):
            return []
        return [address_claim_frame(self.name, self.address)]

    def _on_claim(self, source: int, name: J1939Name, now: float) -> list[Frame]:
        if source > ADDRESS_MAX or name == self.name:
            return []
        self._taken.add(source)
        if self.state is ClaimState.CANNOT_CLAIM or source != self.address:
            return []
        if self.name < name:  # ours has priority: defend the address
            return [address_claim_frame(self.name, self.address)]
        if self.name.arbitrary_address_capable:
            candidate = next_address(self.address, self._taken)
            if candidate is not None:
                self.address = candidate
                return self._claim(now)
        self.state = ClaimState.CANNOT_CLAIM
        self.deadline = None
        return [address_claim_frame(self.name, NULL_ADDRESS)]
