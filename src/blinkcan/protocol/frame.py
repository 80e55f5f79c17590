"""The CAN frame every pure layer speaks: an identifier and up to eight data bytes."""

from __future__ import annotations

from typing import NamedTuple

STANDARD_ID_MAX = 0x7FF
EXTENDED_ID_MAX = 0x1FFFFFFF


_new_tuple = tuple.__new__


class _FrameFields(NamedTuple):
    can_id: int
    data: bytes
    extended: bool


class Frame(_FrameFields):
    """An immutable classic CAN data frame, equal by value.

    A tuple underneath, because twins build hundreds of thousands of these a second.
    """

    __slots__ = ()

    def __new__(cls, can_id: int, data: bytes | bytearray | memoryview = b"",
                extended: bool = False) -> Frame:
        if type(data) is not bytes:
            if not isinstance(data, (bytes, bytearray, memoryview)):
                raise TypeError(f"Frame data must be bytes, not {type(data).__name__}")
            data = bytes(data)
        if len(data) > 8:
            raise ValueError(f"a classic CAN frame carries 0..8 data bytes, got {len(data)}")
        limit = EXTENDED_ID_MAX if extended else STANDARD_ID_MAX
        if not 0 <= can_id <= limit:
            raise ValueError(f"CAN id {can_id:#x} outside 0..{limit:#x}")
        return tuple.__new__(cls, (can_id, data, extended))

    @classmethod
    def trusted(cls, can_id: int, data: bytes, extended: bool = False) -> Frame:
        """Build without checks, for code that made ``data`` itself (a twin's replies)."""
        return _new_tuple(cls, (can_id, data, extended))

    def __repr__(self) -> str:
        ident = f"{self.can_id:08X}" if self.extended else f"{self.can_id:03X}"
        return f"Frame({ident}#{self.data.hex(' ').upper()})"
