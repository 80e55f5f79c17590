"""Drivers for controller applications: Keypad and Keybox on any python-can bus."""

from blinkcan.host.bus import HostBus
from blinkcan.host.device import HealthEvent, Identity
from blinkcan.host.keybox import FaultEvent, Keybox
from blinkcan.host.keypad import KeyEvent, Keypad
from blinkcan.protocol.sdo_client import SdoAbortError, SdoError, SdoTimeoutError

__all__ = [
    "FaultEvent",
    "HealthEvent",
    "HostBus",
    "Identity",
    "KeyEvent",
    "Keybox",
    "Keypad",
    "SdoAbortError",
    "SdoError",
    "SdoTimeoutError",
]
