"""The Keybox driver: outputs, faults, inputs, PWM, configuration, and a host heartbeat the
Keybox can watch, so that if the application dies the Keybox switches its outputs off.

Outputs are commanded by SDO (2001h per pin, 2008h masks): every command is acknowledged, and
SDO acts in pre-operational as well as operational (errata K19). Faults arrive by the fault PDO
(KBX §18); ``fault_poll`` adds polling of 2008h/03 for buses where PDOs may be missed.

The driver keeps two pictures of the outputs. ``commanded``: the pins the application switched
HIGH and has not switched OFF or RESET since (a pin that goes FAULT leaves it: the Keybox latched
it off, and switching it on again is the application's call). ``actual``: every pin's state as
the Keybox last showed it, from acknowledged commands, fault PDOs, reads, and what the Keybox
does by itself (README "Decisions", the twin's fail-safe rules): a boot-up clears every output
and FAULT latch, an NMT stop or reset and a watchdog trip switch HIGH outputs OFF (FAULT stays).
Every FAULT transition of every pin is a :class:`FaultEvent`, in order, on the bus thread:
entering (fault PDO, poll, read) and leaving (an acknowledged RESET, a reboot, a read).
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable, Iterable, Iterator
from collections.abc import Set as AbstractSet
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
from blinkcan.host.device import Device, check_watchdog, confirm_or_close
from blinkcan.host.events import EventSource
from blinkcan.protocol.cob import check_node_id, check_range, check_time
from blinkcan.protocol.frame import Frame
from blinkcan.protocol.items import item_mask, item_numbers
from blinkcan.protocol.nmt import NmtCommand, NmtState
from blinkcan.protocol.sdo_client import SdoError, SdoTimeoutError

log = logging.getLogger(__name__)

STATE_NAMES = PIN_STATE_NAMES


@dataclass(frozen=True)
class FaultEvent:
    pin: int
    fault: bool  # True: the pin went FAULT; False: it left FAULT
    time: float


#: NMT commands after which the Keybox's outputs are OFF (the twin's fail-safe rules)
_OUTPUTS_OFF_AFTER = (NmtCommand.STOP, NmtCommand.RESET_NODE, NmtCommand.RESET_COMMUNICATION)


#: what best-effort work in the background meets when the Keybox is away or the bus is gone: an
#: SDO failure, a closed driver or bus (python-can's CanOperationError from a send on a bus
#: that was shut down), a wait that timed out
_AWAY = (SdoError, RuntimeError, TimeoutError, can.CanError)


def _mask(pins: Iterable[int]) -> int:
    return item_mask(pins, "pin", FACE.pins)


def _pins(mask: int) -> frozenset[int]:
    return frozenset(item_numbers(mask & ((1 << FACE.pins) - 1)))


class Keybox(Device):
    """Drive a Keybox at ``node_id`` on ``bus``.

    ``watchdog``: seconds between host heartbeats; the Keybox is told (1016h) to switch its
    outputs off when they stop for two periods, and a trip is a "watchdog" health event.
    ``host_node_id`` names the host's heartbeat. ``fault_poll``: seconds between polls of the
    FAULT mask (None: the fault PDO only). ``start``: send NMT start now, after every boot-up
    and after a watchdog trip (the outputs stay OFF). ``restore_outputs``: after a reboot or a
    watchdog trip, switch back on the pins in :attr:`commanded` at that moment (off by
    default: a power module should not re-energise loads unasked); when the Keybox watches
    this host's heartbeat (:meth:`watch_host`), only once it watches again: after the next
    host heartbeat this driver sends (none while :meth:`stop_host_heartbeat` holds it), as
    the Keybox re-arms its watchdog only on a heartbeat (KBX §28). ``verify``: confirm that
    a Keybox answers at ``node_id`` first (False only for a device that cannot answer SDO).
    """

    def __init__(self, bus: HostBus | can.BusABC, node_id: int = 0x0C, *, start: bool = True,
                 watchdog: float | None = None, host_node_id: int = 0x7F,
                 fault_poll: float | None = None, restore_outputs: bool = False,
                 sdo_timeout: float = 0.5, verify: bool = True) -> None:
        if watchdog is not None:  # checked before anything is sent (the identity reads)
            check_watchdog(watchdog)
        if fault_poll is not None and check_time("fault poll period", fault_poll) <= 0:
            raise ValueError(f"fault poll period must be > 0 seconds, not {fault_poll!r}")
        check_node_id(host_node_id)  # before the bus is attached
        super().__init__(bus, node_id, describe_keybox("cia301", node_id),
                         sdo_timeout=sdo_timeout)
        self.faults = EventSource[FaultEvent](self.host.scheduler)
        self.fault_pins: frozenset[int] = frozenset()
        self.auto_start = start
        self.restore_outputs = restore_outputs
        self.host_node_id = host_node_id
        self._commanded: frozenset[int] = frozenset()
        #: held while an output command is sent and the driver's picture updated, and while a
        #: restore computes what to send and sends it: the two never interleave
        self._command_lock = threading.Lock()
        self._actual = dict.fromkeys(FACE.pin_numbers, "off")
        self._in_pwm: frozenset[int] = frozenset()
        self._poller: Timer | None = None
        #: a fault poll was handed to the pool and has not ended: the timer hands no other
        self._polling = threading.Event()
        #: the Keybox was told to watch this host's heartbeat (1016h, :meth:`watch_host`)
        self._watches_host = False
        #: a restore waits for the next host heartbeat (the Keybox's watchdog re-arms on it)
        self._restore_when_watched = False
        fault_pdo = self.description.pdo("faults")
        self.listen(fault_pdo.cob_id(node_id), self._on_faults)
        confirm_or_close(self, verify)
        if verify:
            self.states()  # the picture starts true
        if watchdog is not None:
            self.watch_host(watchdog)
        if start:
            self.start()
        if fault_poll is not None:
            self._poller = self.host.call_every(fault_poll, self._schedule_poll,
                                                first=fault_poll)

    # -- the driver's picture ---------------------------------------------------------------------

    @property
    def commanded(self) -> frozenset[int]:
        """The pins the application switched HIGH (and not OFF, RESET, PWM or FAULT since; an
        OFF that timed out counts: what may be off is never restored on)."""
        return self._commanded

    @property
    def actual(self) -> dict[int, str]:
        """Every pin's state ("off", "high", "fault") as the Keybox last showed it; no bus
        traffic (:meth:`states` reads the Keybox)."""
        return dict(self._actual)

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
        with self._command_lock:
            if code != PIN_HIGH:
                self._forget({pin})
            self._command(f"pin_{pin}_state", code)
            self._acknowledged({pin} if code == PIN_HIGH else set(),
                               {pin} if code == PIN_OFF else set(),
                               {pin} if code == PIN_RESET else set())

    def set_outputs(self, high: Iterable[int] = (), off: Iterable[int] = ()) -> None:
        """Pins in ``high`` HIGH, pins in ``off`` OFF, the others unchanged (KBX §21)."""
        high_mask, off_mask = _mask(high), _mask(off)
        if high_mask & off_mask:
            raise ValueError(f"pins {sorted(_pins(high_mask & off_mask))} asked HIGH and OFF")
        with self._command_lock:
            self._write_masks(high_mask, off_mask)

    def _write_masks(self, high_mask: int, off_mask: int) -> None:
        if off_mask:
            self._forget(_pins(off_mask))
            self._command("output_off_mask", off_mask)
            self._acknowledged(set(), _pins(off_mask), set())
        if high_mask:
            self._command("output_high_mask", high_mask)
            self._acknowledged(_pins(high_mask), set(), set())

    def _command(self, name: str, value: int) -> None:
        """Write an output command. One that timed out may have been applied
        (``SdoTimeoutError.uncertain``), and its caller may be gone (an asyncio call cancelled
        meanwhile): ``actual`` keeps what the Keybox last showed, and the driver reads the
        states back in the background, so ``actual`` follows the Keybox once it answers."""
        try:
            self.write(name, value)
        except SdoTimeoutError as error:
            if error.uncertain:
                self.host.spawn(self._confirm_outputs, ("confirm outputs", self.node_id))
            raise

    def _confirm_outputs(self) -> None:
        """Best effort: a read that fails (device away, bus closing) is logged and skipped."""
        try:
            self.states()
        except _AWAY as error:
            log.debug("reading back the outputs of node %02Xh skipped: %s", self.node_id, error)

    def _forget(self, pins: AbstractSet[int]) -> None:
        """Pins the application is switching OFF (or RESET, or into PWM) leave ``commanded``
        before the command is sent, not when it is acknowledged: a command that times out may
        not have been applied (``SdoTimeoutError.uncertain``), and a restore after the
        Keybox's reboot must never switch on what the application last asked to be off."""
        def update() -> None:
            self._commanded -= pins

        self.host.run(update)

    def _acknowledged(self, high: AbstractSet[int], off: AbstractSet[int],
                      reset: AbstractSet[int]) -> None:
        """The Keybox acknowledged a command: both pictures follow (on the bus thread, in
        order with the fault PDOs heard before the acknowledge)."""
        def update() -> None:
            now = self.host.clock()
            for pin in sorted(reset & self.fault_pins):
                self._leave_fault(pin, now)
            for pin in sorted(off | reset):
                if pin not in self.fault_pins:  # KBX §7, errata K12: only RESET clears FAULT
                    self._actual[pin] = "off"
            for pin in sorted(high - self.fault_pins):
                self._actual[pin] = "high"
            self._commanded = (self._commanded - off - reset) | (high - self.fault_pins)
            self._in_pwm -= high | off | reset  # errata K16: a command takes a pin out of PWM

        self.host.run(update)

    def set_pwm(self, pins: Iterable[int], duty: int) -> None:
        """PWM on pins 12 and/or 13 at ``duty`` 0..10 (x 10 %); pins not named leave PWM."""
        chosen = set(pins)
        if not chosen <= set(FACE.pwm_pins):
            raise ValueError(f"PWM is on pins {FACE.pwm_pins} only, not {sorted(chosen)}")
        check_range("PWM duty", duty, 0, PWM_LEVEL_MAX)
        mask = sum(PWM_BITS[pin] for pin in chosen)
        with self._command_lock:
            self._forget(chosen)
            self._command("pwm", pwm_register(mask, duty))
            self.host.run(lambda: self._pwm_acknowledged(frozenset(chosen), duty))

    def _pwm_acknowledged(self, chosen: frozenset[int], duty: int) -> None:
        """errata K16: named pins run PWM (read as HIGH, OFF at duty 0), pins leaving PWM go
        OFF, a pin in FAULT stays FAULT. PWM is not a HIGH command: those pins leave
        ``commanded`` (a restore does not restart PWM)."""
        for pin in sorted(self._in_pwm - chosen - self.fault_pins):
            self._actual[pin] = "off"
        for pin in sorted(chosen - self.fault_pins):
            self._actual[pin] = "high" if duty else "off"
        self._commanded -= self._in_pwm | chosen
        self._in_pwm = chosen - self.fault_pins

    def state(self, pin: int) -> str:
        """"off", "high" or "fault", read from the Keybox (the picture follows)."""
        check_range("pin", pin, 1, FACE.pins)
        state = STATE_NAMES[int(self.read(f"pin_{pin}_state"))]
        self.host.run(lambda: self._seen({pin: state}, self.host.clock()))
        return state

    def states(self) -> dict[int, str]:
        """Every pin's state, from the three 2008h masks (the picture follows)."""
        high = _pins(int(self.read("output_high_mask")))
        fault = _pins(int(self.read("output_fault_mask")))
        states = {p: "fault" if p in fault else "high" if p in high else "off"
                  for p in FACE.pin_numbers}
        self.host.run(lambda: self._seen(states, self.host.clock()))
        return states

    def _seen(self, states: dict[int, str], now: float) -> None:
        """States read from the Keybox replace the picture's; FAULT changes are events."""
        for pin, state in sorted(states.items()):
            if state == "fault":
                self._enter_fault(pin, now)
            elif pin in self.fault_pins:
                self._leave_fault(pin, now)
            self._actual[pin] = state

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
        """The FAULT mask as the Keybox sent or read it: the whole truth about FAULT."""
        pins = _pins(mask)
        for pin in sorted(pins - self.fault_pins):
            self._enter_fault(pin, now)
        for pin in sorted(self.fault_pins - pins):
            self._leave_fault(pin, now)

    def _enter_fault(self, pin: int, now: float) -> None:
        if pin in self.fault_pins:
            return
        self.fault_pins |= {pin}
        self._actual[pin] = "fault"
        self._commanded -= {pin}
        self.faults.emit(FaultEvent(pin, True, now))

    def _leave_fault(self, pin: int, now: float) -> None:
        if pin not in self.fault_pins:
            return
        self.fault_pins -= {pin}
        self._actual[pin] = "off"  # KBX §7: RESET (or a reboot) leaves FAULT to OFF
        self.faults.emit(FaultEvent(pin, False, now))

    def _schedule_poll(self) -> None:
        """The poll timer: one poll at a time per Keybox, so polls of an absent device (each
        waits out its SDO timeout, longer than the period) never pile up. A poll still
        running is not followed by another: in simulated time the timer fires during the
        poll's own wait, and a poll handed over then would run next, and so on for ever."""
        if self._polling.is_set():
            return
        self._polling.set()
        self.host.spawn(self._poll_faults, ("fault poll", self.node_id))

    def _poll_faults(self) -> None:
        """Best effort: a poll that fails (device away, bus closing) is logged and skipped."""
        try:
            mask = int(self.read("output_fault_mask"))
            self.host.run(lambda: self._update_faults(mask, self.host.clock()))
        except _AWAY as error:
            log.debug("fault poll of node %02Xh skipped: %s", self.node_id, error)
        finally:
            self._polling.clear()

    # -- configuration ----------------------------------------------------------------------------

    def set_fault_period(self, period: float) -> None:
        """Send the fault PDO every ``period`` s as well (2012h, 10 ms units); 0 = on change."""
        self.write_period("fault_period", "fault period", period, FAULT_PERIOD_UNIT_S)

    # -- what the Keybox does by itself, and recovery ---------------------------------------------

    def _outputs_went_off(self) -> None:
        """Fail-safe: every HIGH output OFF, PWM stopped; FAULT stays latched."""
        self._in_pwm = frozenset()
        for pin, state in self._actual.items():
            if state == "high":
                self._actual[pin] = "off"

    def nmt_command_seen(self, command: NmtCommand) -> None:
        if command in _OUTPUTS_OFF_AFTER:
            self._outputs_went_off()

    def state_reported(self, state: NmtState, now: float) -> None:
        if state is NmtState.STOPPED:
            self._outputs_went_off()

    def booted_up(self, now: float) -> None:
        for pin in sorted(self.fault_pins):  # a reset clears FAULT latches
            self._leave_fault(pin, now)
        self._actual = dict.fromkeys(self._actual, "off")  # every reset starts with outputs OFF
        self._in_pwm = frozenset()
        self._recover()

    def watchdog_tripped(self, now: float) -> None:
        self._outputs_went_off()  # KBX §28 note 2
        self._recover()

    def set_consumer_heartbeat(self, node_id: int, period: float) -> None:
        super().set_consumer_heartbeat(node_id, period)
        self._watches_host = node_id == self.host_node_id and period > 0

    def _recover(self) -> None:
        if self.auto_start:
            self.start()
        if not self.restore_outputs:
            return
        if self._watches_host:
            # KBX §28: after a trip or a reboot the Keybox watches again from the first
            # heartbeat it hears; outputs switched on before that would stay on unwatched
            self._restore_when_watched = True
            return
        self.host.spawn(self._restore, ("restore outputs", self.node_id))

    def host_heartbeat_sent(self) -> None:
        if self._restore_when_watched:
            self._restore_when_watched = False
            self.host.spawn(self._restore, ("restore outputs", self.node_id))

    def _restore(self) -> None:
        """Switch on what is commanded when this runs, never what was commanded before: an
        application's ``off(4)`` either comes after (and wins) or before (and 4 is left out)."""
        try:
            with self._command_lock:
                self._write_masks(_mask(self._commanded), 0)
        except _AWAY as error:
            log.warning("restoring the outputs of node %02Xh failed: %s", self.node_id, error)

    def close(self) -> None:
        if self._poller is not None:
            self._poller.cancel()
        super().close()
