"""Key behaviours people build on these keypads, ready made: the LED follows the state.

- :class:`Momentary`: on while the key is held.
- :class:`Toggle`: each press flips on/off.
- :class:`Cycle`: each press steps through N states, a colour per state.

They run on the bus thread (sending LED PDOs never blocks); ``on_change(state)`` is called
there too, so hand blocking work (an SDO to a Keybox) to another thread.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

from blinkcan.devices.colours import led_colour
from blinkcan.host.keypad import PRESS, RELEASE, KeyEvent, Keypad
from blinkcan.protocol.cob import check_range


class _KeyBehaviour:
    def __init__(self, keypad: Keypad, key: int, colours: Sequence[str],
                 on_change: Callable[[int], object] | None) -> None:
        face = keypad.description.face  # the model's keys, e.g. 15 on a PKP-3500-MT
        check_range("key", key, 1, face.keys)
        if key not in face.led_keys:
            raise ValueError(f"key {key} has no LED to show its state; keys with one: "
                             f"{', '.join(map(str, face.led_keys))}")
        for colour in colours:
            led_colour(colour)  # ValueError naming the valid colours
        self.keypad = keypad
        self.key = key
        self.colours = tuple(colours)
        self.on_change = on_change
        self.state = 0
        self._remove = keypad.on_key(self._on_key)
        keypad.host.run(self._show)

    def _on_key(self, event: KeyEvent) -> None:
        if event.key == self.key:
            self._react(event.action)

    def _react(self, action: str) -> None:
        raise NotImplementedError

    def set_state(self, state: int) -> None:
        """Set the state as the application decided (the LED follows; no on_change)."""
        self.state = state
        self.keypad.host.run(self._show)

    def _change(self, state: int) -> None:
        if state != self.state:
            self.state = state
            self._show()
            if self.on_change is not None:
                self.on_change(state)

    def _show(self) -> None:
        self.keypad.set_led(self.key, self.colours[self.state])

    def close(self) -> None:
        self._remove()


class _OnOff(_KeyBehaviour):
    """Two states: 0 shows ``off``, 1 shows ``on``."""

    def __init__(self, keypad: Keypad, key: int, on: str = "green", off: str = "off",
                 on_change: Callable[[int], object] | None = None) -> None:
        super().__init__(keypad, key, (off, on), on_change)


class Momentary(_OnOff):
    """State 1 while held, 0 when released."""

    def _react(self, action: str) -> None:
        if action == PRESS:
            self._change(1)
        elif action == RELEASE:
            self._change(0)


class Toggle(_OnOff):
    """Each press flips between 0 and 1."""

    def _react(self, action: str) -> None:
        if action == PRESS:
            self._change(1 - self.state)


class Cycle(_KeyBehaviour):
    """Each press steps to the next of ``len(colours)`` states (0, 1, ..., back to 0)."""

    def __init__(self, keypad: Keypad, key: int, colours: Sequence[str],
                 on_change: Callable[[int], object] | None = None) -> None:
        if len(colours) < 2:
            raise ValueError(f"a cycle needs at least 2 colours, got {len(colours)}")
        super().__init__(keypad, key, colours, on_change)

    def _react(self, action: str) -> None:
        if action == PRESS:
            self._change((self.state + 1) % len(self.colours))
