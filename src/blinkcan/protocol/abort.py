"""CiA 301 SDO abort codes (table 22) and their meanings.

Keybox manual §8 lists four of them; where a request needs another answer, errata.md says to use
the CiA 301 code.
"""

from __future__ import annotations

from enum import IntEnum


class AbortCode(IntEnum):
    """SDO abort codes, sent little-endian in bytes 4-7 of an 80h frame."""

    #: not CiA 301: the PKP-3500-MT manual's code for an unknown command byte (MT M15)
    COMMAND_BYTE_INVALID_BLINK = 0x01000405
    TOGGLE_BIT_NOT_ALTERNATED = 0x05030000
    SDO_PROTOCOL_TIMED_OUT = 0x05040000
    COMMAND_SPECIFIER_INVALID = 0x05040001
    OUT_OF_MEMORY = 0x05040005
    UNSUPPORTED_ACCESS = 0x06010000
    WRITE_ONLY = 0x06010001
    READ_ONLY = 0x06010002
    OBJECT_DOES_NOT_EXIST = 0x06020000
    CANNOT_BE_MAPPED = 0x06040041
    GENERAL_PARAMETER_INCOMPATIBILITY = 0x06040043
    HARDWARE_ERROR = 0x06060000
    DATA_TYPE_LENGTH_MISMATCH = 0x06070010
    DATA_TYPE_LENGTH_TOO_HIGH = 0x06070012
    DATA_TYPE_LENGTH_TOO_LOW = 0x06070013
    SUBINDEX_DOES_NOT_EXIST = 0x06090011
    INVALID_VALUE = 0x06090030
    VALUE_TOO_HIGH = 0x06090031
    VALUE_TOO_LOW = 0x06090032
    GENERAL_ERROR = 0x08000000
    CANNOT_TRANSFER = 0x08000020
    CANNOT_TRANSFER_LOCAL_CONTROL = 0x08000021
    CANNOT_TRANSFER_DEVICE_STATE = 0x08000022

    @property
    def meaning(self) -> str:
        return _MEANINGS[self]


_MEANINGS: dict[AbortCode, str] = {
    AbortCode.COMMAND_BYTE_INVALID_BLINK: "invalid value for command byte (Blink firmware; "
                                          "CiA 301: command specifier not valid)",
    AbortCode.TOGGLE_BIT_NOT_ALTERNATED: "toggle bit not alternated",
    AbortCode.SDO_PROTOCOL_TIMED_OUT: "SDO protocol timed out",
    AbortCode.COMMAND_SPECIFIER_INVALID: "client/server command specifier not valid or unknown",
    AbortCode.OUT_OF_MEMORY: "out of memory",
    AbortCode.UNSUPPORTED_ACCESS: "unsupported access to an object",
    AbortCode.WRITE_ONLY: "attempt to read a write only object",
    AbortCode.READ_ONLY: "attempt to write a read only object",
    AbortCode.OBJECT_DOES_NOT_EXIST: "object does not exist in the object dictionary",
    AbortCode.CANNOT_BE_MAPPED: "object cannot be mapped to the PDO",
    AbortCode.GENERAL_PARAMETER_INCOMPATIBILITY: "general parameter incompatibility",
    AbortCode.HARDWARE_ERROR: "access failed due to a hardware error",
    AbortCode.DATA_TYPE_LENGTH_MISMATCH: "data type does not match, length does not match",
    AbortCode.DATA_TYPE_LENGTH_TOO_HIGH: "data type does not match, length too high",
    AbortCode.DATA_TYPE_LENGTH_TOO_LOW: "data type does not match, length too low",
    AbortCode.SUBINDEX_DOES_NOT_EXIST: "sub-index does not exist",
    AbortCode.INVALID_VALUE: "invalid value for parameter",
    AbortCode.VALUE_TOO_HIGH: "value of parameter written too high",
    AbortCode.VALUE_TOO_LOW: "value of parameter written too low",
    AbortCode.GENERAL_ERROR: "general error",
    AbortCode.CANNOT_TRANSFER: "data cannot be transferred or stored to the application",
    AbortCode.CANNOT_TRANSFER_LOCAL_CONTROL: "data cannot be transferred because of local control",
    AbortCode.CANNOT_TRANSFER_DEVICE_STATE: (
        "data cannot be transferred in the present device state"
    ),
}


def describe_abort(code: int) -> str:
    """The CiA 301 meaning of an abort code, or a plain 'unknown abort code' text."""
    try:
        return AbortCode(code).meaning
    except ValueError:
        return f"unknown abort code {code:08X}h"
