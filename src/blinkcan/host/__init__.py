"""Drivers for controller applications: Keypad and Keybox on any python-can bus."""

from blinkcan.host.aio import AsyncKeybox, AsyncKeypad, async_scan
from blinkcan.host.behaviours import Cycle, Momentary, Toggle
from blinkcan.host.bus import HostBus
from blinkcan.host.device import HealthEvent, Identity, NoDeviceError, WrongDeviceError
from blinkcan.host.identity_errors import IdentityError, SharedNodeIdError
from blinkcan.host.j1939_keypad import FoundJ1939, scan_j1939
from blinkcan.host.keybox import FaultEvent, Keybox
from blinkcan.host.keypad import KeyEvent, Keypad
from blinkcan.host.scan import Found, scan
from blinkcan.protocol.sdo_client import SdoAbortError, SdoError, SdoTimeoutError

__all__ = [
    "AsyncKeybox",
    "AsyncKeypad",
    "Cycle",
    "FaultEvent",
    "Found",
    "FoundJ1939",
    "HealthEvent",
    "HostBus",
    "Identity",
    "IdentityError",
    "KeyEvent",
    "Keybox",
    "Keypad",
    "Momentary",
    "NoDeviceError",
    "SdoAbortError",
    "SdoError",
    "SdoTimeoutError",
    "SharedNodeIdError",
    "Toggle",
    "WrongDeviceError",
    "async_scan",
    "scan",
    "scan_j1939",
]
