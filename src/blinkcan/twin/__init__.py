"""Pure device behaviour: twins that answer frames as the real devices do. Time is an argument."""

from blinkcan.twin.base import CanopenTwin
from blinkcan.twin.keypad import KeypadTwin
from blinkcan.twin.nvm import JsonFileNvm, MemoryNvm, NvmError

__all__ = ["CanopenTwin", "JsonFileNvm", "KeypadTwin", "MemoryNvm", "NvmError"]
