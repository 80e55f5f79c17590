"""Pure device behaviour: twins that answer frames as the real devices do. Time is an argument."""

from blinkcan.twin.base import CanopenTwin
from blinkcan.twin.keybox import KeyboxTwin
from blinkcan.twin.keypad import KeypadTwin
from blinkcan.twin.nvm import JsonFileNvm, MemoryNvm, NvmError

__all__ = ["CanopenTwin", "JsonFileNvm", "KeyboxTwin", "KeypadTwin", "MemoryNvm", "NvmError"]
