"""Pure device descriptions: object tables and PDO layouts per model and firmware generation."""

from blinkcan.devices.keybox import describe_keybox
from blinkcan.devices.keypad import describe_keypad
from blinkcan.devices.model import DeviceDescription
from blinkcan.devices.objects import Access, DataType, ObjectEntry, ObjectTable
from blinkcan.devices.pdo import PdoLayout, PdoSignal

__all__ = [
    "Access",
    "DataType",
    "DeviceDescription",
    "ObjectEntry",
    "ObjectTable",
    "PdoLayout",
    "PdoSignal",
    "describe_keybox",
    "describe_keypad",
]
