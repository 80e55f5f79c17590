"""The Keybox driver: outputs, faults, inputs, PWM, configuration, and a host heartbeat the
Keybox can watch, so that if the application dies the Keybox switches its outputs off.

Outputs are commanded by SDO (2001h per pin, 2008h masks): every command is acknowledged, and
SDO acts in pre-operational as well as operational (errata K19). Faults arrive by the fault PDO
(KBX §18); ``fault_poll`` adds polling of 2008h/03 for buses where PDOs may be missed.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass

import can

from blinkcan.devices.keybox import (
    FACE,
    FAULT_PERIOD_UNIT_S,
    PIN_HIGH,
    PIN_OFF,
    PIN_RESET,
    PIN_STATE_NAMES,
    PWM_BITS,
    PWM_LEVEL_MAX,
    describe_keybox,
    pwm_register,
)
from blinkcan.host.bus import HostBus, Timer
from blinkcan.host.device import Device
from blinkcan.host.events import EventSource
from blinkcan.protocol.cob import check_node_id, check_range
from blinkcan.protocol.frame import Frame
from blinkcan.protocol.items import item_mask, item_numbers
from blinkcan.protocol.sdo_client import SdoError

log = logging.getLogger(__name__)

STATE_NAMES = PIN_STATE_NAMES


@dataclass(frozen=True)
class FaultEvent:
    pin: int
    fault: bool  # True: the pin went FAULT; False: it left FAULT
    time: float


def _mask(pins: Iterable[int]) -> int:
    return item_mask(pins, "pin", FACE.pins)


def _pins(mask: int) -> frozenset[int]:
    return frozenset(item_numbers(mask & ((1 << FACE.pins) - 1)))


class Keybox(Device):
    """Drive a Keybox at ``node_id`` on ``bus``.

    ``watchdog``: seconds between host heartbeats; the Keybox is told (1016h) to switch its
    outputs off when they stop for two periods. ``host_node_id`` names the host's heartbeat.
    ``fault_poll``: seconds between polls of the FAULT mask (None: the fault PDO only).
    ``restore_outputs``: after the Keybox reboots, switch back on the outputs this driver had
    switched on (off by default: a rebooted power module should not re-energise loads unasked).
    """

    def __init__(self, bus: HostBus | can.BusABC, node_id: int = 0x0C, *, start: bool = True,
                 watchdog: float | None = None, host_node_id: int = 0x7F,
                 fault_poll: float | None = None, restore_outputs: bool = False,
                 sdo_timeout: float = 0.5) -> None:
        super().__init__(bus, node_id, describe_keybox("cia301", node_id),
                         sdo_timeout=sdo_timeout)
        self.faults = EventSource[FaultEvent](self.host.scheduler)
        self.fault_pins: frozenset[int] = frozenset()
        self.auto_start = start
        self.restore_outputs = restore_outputs
        self.commanded_high: set[int] = set()
        self.host_node_id = check_node_id(host_node_id)
        self._poller: Timer | None = None
        fault_pdo = self.description.pdo("faults")
        self._unsubscribe.append(self.host.subscribe(fault_pdo.cob_id(node_id), self._on_faults))
        if watchdog is not None:
            self.watch_host(watchdog)
        if start:
            self.start()
        if fault_poll is not None:
            # one poll at a time per Keybox: polls of an absent device never pile up
            self._poller = self.host.call_every(
                fault_poll, lambda: self.host.spawn(self._poll_faults, ("fault poll", node_id)),
                first=fault_poll)

    # -- outputs ----------------------------------------------------------------------------------

    def on(self, pin: int) -> None:
        """Output ``pin`` (1..13) HIGH (KBX §19)."""
        self._pin(pin, PIN_HIGH)

    def off(self, pin: int) -> None:
        self._pin(pin, PIN_OFF)

    def reset(self, pin: int | None = None) -> None:
        """RESET a pin out of FAULT to OFF (KBX §7). Without a pin: NMT reset of the Keybox."""
        if pin is None:
            super().reset()
            return
        self._pin(pin, PIN_RESET)

    def _pin(self, pin: int, code: int) -> None:
        check_range("pin", pin, 1, FACE.pins)
        self.write(f"pin_{pin}_state", code)
        if code == PIN_HIGH:
            self.commanded_high.add(pin)
        else:
            self.commanded_high.discard(pin)

    def set_outputs(self, high: Iterable[int] = (), off: Iterable[int] = ()) -> None:
        """Pins in ``high`` HIGH, pins in ``off`` OFF, the others unchanged (KBX §21)."""
        high_mask, off_mask = _mask(high), _mask(off)
        if high_mask & off_mask:
            raise ValueError(f"pins {sorted(_pins(high_mask & off_mask))} asked HIGH and OFF")
        if off_mask:
            self.write("output_off_mask", off_mask)
            self.commanded_high -= _pins(off_mask)
        if high_mask:
            self.write("output_high_mask", high_mask)
            self.commanded_high |= _pins(high_mask)

    def set_pwm(self, pins: Iterable[int], duty: int) -> None:
        """PWM on pins 12 and/or 13 at ``duty`` 0..10 (x 10 %); pins not named leave PWM."""
        chosen = set(pins)
        if not chosen <= set(FACE.pwm_pins):
            raise ValueError(f"PWM is on pins {FACE.pwm_pins} only, not {sorted(chosen)}")
        check_range("PWM duty", duty, 0, PWM_LEVEL_MAX)
        mask = sum(PWM_BITS[pin] for pin in chosen)
        self.write("pwm", pwm_register(mask, duty))

    def state(self, pin: int) -> str:
        """"off", "high" or "fault"."""
        check_range("pin", pin, 1, FACE.pins)
        return STATE_NAMES[int(self.read(f"pin_{pin}_state"))]

    def states(self) -> dict[int, str]:
        """Every pin's state, from the three 2008h masks."""
        high = _pins(int(self.read("output_high_mask")))
        fault = _pins(int(self.read("output_fault_mask")))
        return {p: "fault" if p in fault else "high" if p in high else "off"
                for p in FACE.pin_numbers}

    def inputs(self) -> dict[int, bool]:
        """The level on every pin (2003h/01, errata K21)."""
        levels = int(self.read("input_levels"))
        return {p: bool(levels >> (p - 1) & 1) for p in FACE.pin_numbers}

    # -- faults -----------------------------------------------------------------------------------

    def on_fault(self, callback: Callable[[FaultEvent], object]) -> Callable[[], None]:
        return self.faults.subscribe(callback)

    def fault_events(self, timeout: float | None = None) -> Iterator[FaultEvent]:
        return self.faults.iterate(timeout)

    def _on_faults(self, frame: Frame, now: float) -> None:
        layout = self.description.pdo("faults")
        if len(frame.data) >= layout.min_length:  # KBX §18: DLC 2 or more
            self._update_faults(layout.decode(frame.data)["faults"], now)

    def _update_faults(self, mask: int, now: float) -> None:
        pins = _pins(mask)
        before, self.fault_pins = self.fault_pins, pins
        for pin in sorted(pins - before):
            self.faults.emit(FaultEvent(pin, True, now))
        for pin in sorted(before - pins):
            self.faults.emit(FaultEvent(pin, False, now))

    def _poll_faults(self) -> None:
        """Best effort: a poll that fails (device away, bus closing) is logged and skipped."""
        try:
            mask = int(self.read("output_fault_mask"))
            self.host.run(lambda: self._update_faults(mask, self.host.clock()))
        except (SdoError, RuntimeError, TimeoutError) as error:
            log.debug("fault poll of node %02Xh skipped: %s", self.node_id, error)

    # -- configuration ----------------------------------------------------------------------------

    def set_fault_period(self, period: float) -> None:
        """Send the fault PDO every ``period`` s as well (2012h, 10 ms units); 0 = on change."""
        self.write("fault_period", round(period / FAULT_PERIOD_UNIT_S))

    # -- recovery and lifecycle -------------------------------------------------------------------

    def _on_boot_up(self, now: float) -> None:
        self.fault_pins = frozenset()  # a reset clears FAULT latches; outputs start OFF
        if self.auto_start:
            self.start()
        if self.restore_outputs and self.commanded_high:
            pins = sorted(self.commanded_high)
            self.host.spawn(lambda: self.set_outputs(high=pins))

    def close(self) -> None:
        if self._poller is not None:
            self._poller.cancel()
        super().close()
