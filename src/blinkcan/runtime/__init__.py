"""The only layer with threads, clocks and python-can: twins on a real or virtual bus."""

from blinkcan.runtime.canbus import open_bus, to_frame, to_message
from blinkcan.runtime.emulator import Emulator, EmulatorStats

__all__ = ["Emulator", "EmulatorStats", "open_bus", "to_frame", "to_message"]
