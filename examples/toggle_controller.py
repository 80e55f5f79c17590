"""A small controller: key N toggles Keybox output N; a faulted output blinks its key red.

It takes any python-can bus: a real one in the boat, ``Rig().bus`` in its tests
(``examples/test_toggle_controller.py``), so the same code is tested in simulated time.

The pattern to copy: the LEDs show what the Keybox reports, never what this controller
remembers sending. A Keybox that reboots (power cycle, brown-out) or trips its watchdog switches
its outputs off by itself; its health events say so, and the controller reads the outputs again
and re-derives every LED from them.
"""

from __future__ import annotations

import can

from blinkcan import Keybox, Keypad
from blinkcan.host import FaultEvent, HealthEvent, KeyEvent

#: the Keybox's own news that its outputs may have changed without a command of ours
RESYNC_ON = ("boot-up", "watchdog", "back")


class ToggleController:
    """Key N toggles output N (LED green while it is HIGH); an output in FAULT blinks its key
    red until the key is pressed, which resets the output."""

    def __init__(self, bus: can.BusABC, keypad_node: int = 0x15, keybox_node: int = 0x0C,
                 watchdog: float = 0.1) -> None:
        self.keypad = Keypad(bus, keypad_node)
        self.keybox = Keybox(bus, keybox_node, watchdog=watchdog)  # outputs off if we die
        self.keys = range(1, 13)  # the keys that switch outputs
        self.keypad.keys.subscribe(self._on_key)
        self.keybox.faults.subscribe(self._on_fault)
        self.keybox.health.subscribe(self._on_keybox_health)

    def _on_key(self, event: KeyEvent) -> None:
        if event.action != "press" or event.key not in self.keys:
            return
        # handlers must not block: the SDO commands run off the bus thread
        self.keypad.host.spawn(lambda: self._toggle(event.key))

    def _toggle(self, pin: int) -> None:
        state = self.keybox.actual[pin]  # what the Keybox last reported
        if state == "fault":
            self.keybox.reset(pin)
        elif state == "high":
            self.keybox.off(pin)
        else:
            self.keybox.on(pin)
        self._show(pin)

    def _show(self, pin: int) -> None:
        """Key ``pin``'s LED from the Keybox's state of output ``pin``."""
        state = self.keybox.actual[pin]
        if state == "fault":
            self.keypad.set_led(pin, "red", blink="off")
        else:
            self.keypad.set_led(pin, "green" if state == "high" else "off")

    def _on_fault(self, event: FaultEvent) -> None:
        if event.pin in self.keys:
            self._show(event.pin)

    def _on_keybox_health(self, event: HealthEvent) -> None:
        if event.kind in RESYNC_ON:
            self.keypad.host.spawn(self._resync, key="resync")

    def _resync(self) -> None:
        """Read every output from the Keybox and show it (after a reboot all are OFF)."""
        self.keybox.states()
        with self.keypad.batch():
            for pin in self.keys:
                self._show(pin)

    def close(self) -> None:
        self.keypad.close()
        self.keybox.close()
