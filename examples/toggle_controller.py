"""A small controller: key N toggles Keybox output N; a faulted output blinks its key red.

It takes any python-can bus: a real one in the boat, ``Rig().bus`` in its tests
(``examples/test_toggle_controller.py``), so the same code is tested in simulated time.
"""

from __future__ import annotations

import can

from blinkcan import Keybox, Keypad
from blinkcan.host import FaultEvent, KeyEvent


class ToggleController:
    """Key N toggles output N (LED green when on); an output in FAULT blinks its key red
    until the key is pressed, which resets the output."""

    def __init__(self, bus: can.BusABC, keypad_node: int = 0x15, keybox_node: int = 0x0C,
                 watchdog: float = 0.1) -> None:
        self.keypad = Keypad(bus, keypad_node)
        self.keybox = Keybox(bus, keybox_node, watchdog=watchdog)  # outputs off if we die
        self.on: set[int] = set()
        self.faulted: set[int] = set()
        self.keypad.keys.subscribe(self._on_key)
        self.keybox.faults.subscribe(self._on_fault)

    def _on_key(self, event: KeyEvent) -> None:
        if event.action != "press" or event.key > 12:
            return
        # handlers must not block: the SDO commands run off the bus thread
        self.keypad.host.spawn(lambda: self._toggle(event.key))

    def _toggle(self, pin: int) -> None:
        if pin in self.faulted:
            self.keybox.reset(pin)
            self.faulted.discard(pin)
            self.on.discard(pin)
        elif pin in self.on:
            self.keybox.off(pin)
            self.on.discard(pin)
        else:
            self.keybox.on(pin)
            self.on.add(pin)
        self.keypad.set_led(pin, "green" if pin in self.on else "off")

    def _on_fault(self, event: FaultEvent) -> None:
        if event.fault and event.pin <= 12:
            self.faulted.add(event.pin)
            self.keypad.set_led(event.pin, "red", blink="off")

    def close(self) -> None:
        self.keypad.close()
        self.keybox.close()
