"""The Keybox's 13 outputs: OFF, HIGH or FAULT, fuses, PWM on pins 12/13, input levels.

The state machine of KBX §7 as a table. A pin commanded HIGH whose fuse is blown, or whose fuse
blows while HIGH, goes FAULT; FAULT is latched until RESET (errata K12: OFF does not clear it),
which returns it to OFF. Low-side pins (Ch2/Ch5 as built, errata K22) detect no faults (KBX §7).

PWM (errata K16): one register, a mask of pins 12/13 and one duty level. A pin in PWM reads as
HIGH (as OFF at duty 0); a pin leaving PWM, or commanded while in PWM, leaves PWM. A fault in
PWM is latched like any other but not reported by a fault PDO (KBX §18 note, §22 note 2).
"""

from __future__ import annotations

from enum import Enum, IntEnum

from blinkcan.devices.keybox import FACE, PWM_BITS, commanded_outputs, pwm_register
from blinkcan.protocol.cob import check_range
from blinkcan.protocol.items import item_numbers


class PinState(IntEnum):
    """The 2001h codes (KBX §19)."""

    OFF = 0x00
    HIGH = 0x01
    FAULT = 0x03


class PinEvent(Enum):
    # members are singletons, equal only to themselves: the identity hash agrees with that and
    # is a C slot, where Enum's hashes the name in Python (TRANSITIONS is read per command)
    __hash__ = object.__hash__

    COMMAND_OFF = "off"
    COMMAND_HIGH = "high"  # fuse intact, or a pin that cannot detect faults
    COMMAND_HIGH_FUSE_BLOWN = "high, fuse blown"
    RESET = "reset"
    FUSE_BLOWS = "fuse blows"


#: (state, event) -> next state (KBX §7, errata K12)
TRANSITIONS: dict[tuple[PinState, PinEvent], PinState] = {
    (PinState.OFF, PinEvent.COMMAND_OFF): PinState.OFF,
    (PinState.OFF, PinEvent.COMMAND_HIGH): PinState.HIGH,
    (PinState.OFF, PinEvent.COMMAND_HIGH_FUSE_BLOWN): PinState.FAULT,
    (PinState.OFF, PinEvent.RESET): PinState.OFF,
    (PinState.OFF, PinEvent.FUSE_BLOWS): PinState.OFF,  # detected once commanded HIGH
    (PinState.HIGH, PinEvent.COMMAND_OFF): PinState.OFF,
    (PinState.HIGH, PinEvent.COMMAND_HIGH): PinState.HIGH,
    (PinState.HIGH, PinEvent.COMMAND_HIGH_FUSE_BLOWN): PinState.FAULT,
    (PinState.HIGH, PinEvent.RESET): PinState.OFF,
    (PinState.HIGH, PinEvent.FUSE_BLOWS): PinState.FAULT,
    (PinState.FAULT, PinEvent.COMMAND_OFF): PinState.FAULT,  # K12: only RESET clears FAULT
    (PinState.FAULT, PinEvent.COMMAND_HIGH): PinState.FAULT,
    (PinState.FAULT, PinEvent.COMMAND_HIGH_FUSE_BLOWN): PinState.FAULT,
    (PinState.FAULT, PinEvent.RESET): PinState.OFF,
    (PinState.FAULT, PinEvent.FUSE_BLOWS): PinState.FAULT,
}

_PINS = FACE.pins
_PWM_BITS = PWM_BITS


def check_pin(pin: int) -> int:
    return check_range("pin", pin, 1, _PINS)


def pins_of(mask: int) -> list[int]:
    """The pins (1..13) whose bits are set, lowest first."""
    return item_numbers(mask)


class Outputs:
    """Live state of the 13 outputs; fuses and external levels are the physical side."""

    def __init__(self, low_side: frozenset[int] = frozenset()) -> None:
        self.low_side = low_side
        self.fuse_ok = [True] * _PINS
        self.external = [False] * _PINS
        self.power_on()

    def power_on(self) -> None:
        """Every output OFF, no latched fault, no PWM (live state after power-on or reset)."""
        self.state = [PinState.OFF] * _PINS
        self.pwm_mask = 0  # bit 0 = pin 12, bit 1 = pin 13 (KBX §22)
        self.pwm_level = 0

    # -- commands -------------------------------------------------------------------------

    def _apply(self, pin: int, event: PinEvent) -> bool:
        """Apply one event; True when the pin newly entered FAULT."""
        before = self.state[pin - 1]
        after = TRANSITIONS[before, event]
        self.state[pin - 1] = after
        return after is PinState.FAULT and before is not PinState.FAULT

    def _detects_faults(self, pin: int) -> bool:
        return pin not in self.low_side

    def _leave_pwm(self, pin: int) -> None:
        self.pwm_mask &= ~_PWM_BITS.get(pin, 0)

    def command(self, pin: int, state: int) -> list[int]:
        """A 2001h code (00h OFF, 01h HIGH, 02h RESET) for one pin; the pins that newly
        entered FAULT and must be reported."""
        self._leave_pwm(pin)
        if state == PinState.OFF:
            event = PinEvent.COMMAND_OFF
        elif state == PinState.HIGH:
            blown = not self.fuse_ok[pin - 1] and self._detects_faults(pin)
            event = PinEvent.COMMAND_HIGH_FUSE_BLOWN if blown else PinEvent.COMMAND_HIGH
        else:
            event = PinEvent.RESET
        return [pin] if self._apply(pin, event) else []

    def command_masks(self, off: int, high: int) -> list[int]:
        """KBX §17/§21 (errata K12, K20): pins in ``off`` go OFF, pins in ``high`` go HIGH,
        others are unchanged; OFF wins where both are set."""
        off, high = commanded_outputs(off, high)
        faults: list[int] = []
        for pin in pins_of(off):
            faults += self.command(pin, PinState.OFF)
        for pin in pins_of(high):
            faults += self.command(pin, PinState.HIGH)
        return faults

    def set_pwm(self, mask: int, level: int) -> list[int]:
        """Write the PWM register (errata K16). A pin in FAULT stays FAULT, out of PWM."""
        faults: list[int] = []
        for pin, bit in _PWM_BITS.items():
            index = pin - 1
            if mask & bit:
                if self.state[index] is PinState.FAULT:
                    mask &= ~bit
                    continue
                driven = level > 0
                if driven and not self.fuse_ok[index] and self._detects_faults(pin):
                    self._apply(pin, PinEvent.COMMAND_HIGH_FUSE_BLOWN)  # not reported (§22)
                    mask &= ~bit
                    continue
                self.state[index] = PinState.HIGH if driven else PinState.OFF
            elif self.pwm_mask & bit:
                self.state[index] = PinState.OFF  # leaving PWM goes OFF
        self.pwm_mask, self.pwm_level = mask, level
        return faults

    def all_off(self) -> None:
        """Fail-safe: every HIGH output OFF, PWM stopped; FAULT stays latched."""
        self.pwm_mask = 0
        self.state = [PinState.FAULT if s is PinState.FAULT else PinState.OFF for s in self.state]

    # -- physical side ----------------------------------------------------------------------

    def blow_fuse(self, pin: int) -> list[int]:
        self.fuse_ok[pin - 1] = False
        if not self._detects_faults(pin):
            return []
        in_pwm = bool(self.pwm_mask & _PWM_BITS.get(pin, 0))
        entered = self._apply(pin, PinEvent.FUSE_BLOWS)
        if entered and in_pwm:
            self._leave_pwm(pin)
            return []  # KBX §18 note: no fault message for a fault during PWM
        return [pin] if entered else []

    def replace_fuse(self, pin: int) -> None:
        self.fuse_ok[pin - 1] = True  # a FAULT stays latched until RESET

    # -- what the objects read --------------------------------------------------------------

    def mask(self, state: PinState) -> int:
        return sum(1 << i for i, s in enumerate(self.state) if s is state)

    def in_pwm(self, pin: int) -> bool:
        return bool(self.pwm_mask & _PWM_BITS.get(pin, 0))

    def input_levels(self) -> int:
        """2003h/01 (errata K21): the external level, or a high-side output driven HIGH with
        its fuse intact; a low-side output driven HIGH pulls its pin to ground."""
        levels = 0
        for i in range(_PINS):
            pin = i + 1
            driven = self.state[i] is PinState.HIGH
            if driven and pin in self.low_side:
                level = False
            elif driven and self.fuse_ok[i]:
                level = True
            else:
                level = self.external[i]
            levels |= level << i
        return levels & ((1 << _PINS) - 1)

    def pwm_register(self) -> int:
        return pwm_register(self.pwm_mask, self.pwm_level)
