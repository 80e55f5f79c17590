"""A controller written with plain python-can and cantools: key N toggles Keybox output N.

Every frame is encoded and decoded with the DBC files of the devices (``blinkcan export dbc
keypad`` / ``keybox``, or :func:`blinkcan.formats.dbc.database` as here); a ``can.Notifier``
hands the frames to the controller. Its tests (``examples/test_cantools_controller.py``) run it
against the twins on ``Rig().bus``, in simulated time: the rig drives the notifier.

What it does: the keypad's key-state PDO toggles the matching output (Keybox output PDO) and
its LED (green while the output is on); the Keybox's fault PDO turns a faulted output's LED red;
the Keybox's heartbeat is watched (``keybox_alive``), and its boot-up after a power cycle makes
the controller start it again and send its outputs again (it boots with every output OFF).
Time comes from ``clock`` (wall time in the field, where python-can stamps frames with it; the
rig's virtual time in tests).
"""

from __future__ import annotations

import struct
import time
from collections.abc import Callable
from typing import Any

import can

from blinkcan.devices.registry import describe_device
from blinkcan.formats.dbc import database

NMT_START = 0x01  # CiA 301 NMT command: start remote node
SDO_WRITE_2_BYTES = 0x2B  # CiA 301 expedited download of 2 bytes


class CantoolsToggleController:
    """Key N toggles output N; LEDs green while on, red on a fault."""

    def __init__(self, bus: can.BusABC, keypad_node: int = 0x15, keybox_node: int = 0x0C,
                 heartbeat_ms: int = 100, clock: Callable[[], float] = time.time) -> None:
        self.bus = bus
        self.clock = clock
        self.keypad_db = database(describe_device("keypad"), keypad_node)
        self.keybox_db = database(describe_device("keybox"), keybox_node)
        self.keypad_name = f"KEYPAD_{keypad_node:02X}"
        self.keybox_name = f"KEYBOX_{keybox_node:02X}"
        self.keybox_node = keybox_node
        self.heartbeat = heartbeat_ms / 1000
        self.on: set[int] = set()
        self.faults: set[int] = set()
        self.last_heartbeat: float | None = None
        self._pressed: set[int] = set()
        self._handlers: dict[str, Callable[[Any, float], None]] = {
            f"{self.keypad_name}_KEY_STATE": self._on_keys,
            f"{self.keybox_name}_FAULTS": self._on_faults,
            f"{self.keybox_name}_HEARTBEAT": self._on_keybox_heartbeat,
        }
        self.notifier = can.Notifier(bus, [self._on_message])
        for node in (keypad_node, keybox_node):  # heartbeats on (1017h), then start
            bus.send(can.Message(arbitration_id=0x600 + node, is_extended_id=False,
                                 data=struct.pack("<BHBH2x", SDO_WRITE_2_BYTES, 0x1017, 0,
                                                  heartbeat_ms)))
        bus.send(can.Message(arbitration_id=0x000, data=[NMT_START, 0], is_extended_id=False))

    def keybox_alive(self) -> bool:
        """A Keybox heartbeat came within the last three periods."""
        return (self.last_heartbeat is not None
                and self.clock() - self.last_heartbeat <= 3 * self.heartbeat)

    # -- the notifier's listener: decode, decide, encode -------------------------------------

    def _on_message(self, msg: can.Message) -> None:
        for db in (self.keypad_db, self.keybox_db):
            try:
                message = db.get_message_by_frame_id(msg.arbitration_id)
            except KeyError:
                continue
            handler = self._handlers.get(message.name)
            if handler is not None:
                handler(message.decode(bytes(msg.data)), msg.timestamp)

    def _on_keys(self, signals: dict[str, int], _when: float) -> None:
        pressed = {key for key in range(1, 13) if signals[f"keys_{key}"]}
        for key in sorted(pressed - self._pressed):
            self.on ^= {key}
            self.faults.discard(key)
        self._pressed = pressed
        self._send_outputs()
        self._send_leds()

    def _on_faults(self, signals: dict[str, int], _when: float) -> None:
        self.faults = {pin for pin in range(1, 14) if signals[f"faults_{pin}"]}
        self.on -= self.faults
        self._send_leds()

    def _on_keybox_heartbeat(self, signals: dict[str, Any], when: float) -> None:
        self.last_heartbeat = when
        if signals["state"] == "boot_up":  # rebooted: every output OFF, pre-operational
            self.bus.send(can.Message(arbitration_id=0x000, is_extended_id=False,
                                      data=[NMT_START, self.keybox_node]))
            self._send_outputs()

    # -- frames out, encoded from the DBC -----------------------------------------------------

    def _send(self, db: Any, name: str, signals: dict[str, int]) -> None:
        message = db.get_message_by_name(name)
        self.bus.send(can.Message(arbitration_id=message.frame_id, is_extended_id=False,
                                  data=message.encode(signals)))

    def _send_outputs(self) -> None:
        signals = {f"high_{pin}": int(pin in self.on) for pin in range(1, 14)}
        signals |= {f"off_{pin}": int(pin not in self.on) for pin in range(1, 14)}
        self._send(self.keybox_db, f"{self.keybox_name}_OUTPUTS", signals)

    def _send_leds(self) -> None:
        signals = {}
        for key in range(1, 13):
            signals[f"red_{key}"] = int(key in self.faults)
            signals[f"green_{key}"] = int(key in self.on)
            signals[f"blue_{key}"] = 0
        self._send(self.keypad_db, f"{self.keypad_name}_LED_ON", signals)

    def close(self) -> None:
        self.notifier.stop()
