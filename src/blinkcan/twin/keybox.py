"""The Keybox twin (`keybox-canopen-manual.txt`): 13 outputs with fuses, fault reporting,
PWM, inputs, consumer heartbeat and restore defaults, on top of :class:`CanopenTwin`.

Where the manual is silent about outputs, the twin is fail-safe (blinkcan decisions):
- NMT stop switches every output OFF (a stopped node must not keep loads powered); enter
  pre-operational keeps them (SDO still drives outputs there, errata K19).
- Reset node, reset communication and power-on start with every output OFF.
- FAULT stays latched through OFF commands and heartbeat loss, until RESET or a power cycle.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from typing import Any

from blinkcan.devices.keybox import (
    DEFAULT_NODE_ID,
    FACE,
    FAULT_PERIOD_UNIT_S,
    KEYBOX,
    MODEL,
    PIN_STATE_NAMES,
    PWM_LEVEL_MAX,
    PWM_MASK,
    split_pwm_register,
)
from blinkcan.devices.model import Quirks
from blinkcan.devices.objects import Value
from blinkcan.devices.pdo import PdoLayout
from blinkcan.protocol.abort import AbortCode
from blinkcan.protocol.cob import check_time
from blinkcan.protocol.frame import Frame
from blinkcan.protocol.nmt import NmtState
from blinkcan.twin.base import CanopenTwin
from blinkcan.twin.keybox_outputs import Outputs, PinState, check_pin
from blinkcan.twin.nvm import NvmArgument

_STATE_NAMES = {state: PIN_STATE_NAMES[state] for state in PinState}
_PIN_ENTRIES = tuple(f"pin_{pin}_state" for pin in FACE.pin_numbers)


class KeyboxTwin(CanopenTwin):
    """A Keybox that behaves on the bus as the manual describes, with fault injection.

    ``low_side`` names the pins built as low-side drivers (only 2 and 5 can be, errata K22).
    """

    def __init__(
        self,
        node_id: int = DEFAULT_NODE_ID,
        quirks: Quirks = "firmware",
        nvm: NvmArgument = None,
        low_side: Iterable[int] = (),
        settings: Mapping[str, Value] | None = None,
        model: str = MODEL,
    ) -> None:
        if model != MODEL:
            raise ValueError(f"the Keybox twin runs model {MODEL!r}, not {model!r}")
        low = frozenset(low_side)
        capable = FACE.low_side_capable
        if not low <= set(capable):
            raise ValueError(f"only pins {capable} can be built low-side, not "
                             f"{sorted(low - set(capable))}")
        description = KEYBOX.description(quirks=quirks, factory_node_id=node_id)
        super().__init__(description, node_id, nvm, settings)
        self.outputs = Outputs(low)
        self._shown_states: list[PinState | None] = [None] * FACE.pins
        self._inputs_changed = True
        self._fault_pdo: PdoLayout = description.pdo("faults")
        self._fault_frame_cache: Frame | None = None
        self._faults = self.add_timer(self._periodic_faults)
        for pin in FACE.pin_numbers:
            self.on_write(f"pin_{pin}_state", self._pin_hook(pin), keeps_value=False)
        self.on_write("output_off_mask", self._on_off_mask, keeps_value=False)
        self.on_write("output_high_mask", self._on_high_mask, keeps_value=False)
        self.on_write("pwm", self._on_pwm, keeps_value=False)
        self.on_write("fault_period", self._on_fault_period)
        self.on_rpdo("outputs", self._on_outputs_pdo)
        self.on_boot(self._on_boot)
        self.on_power_off(self.outputs.power_on)
        self.on_state_change(self._on_state_change)
        self.on_consumer_lost(self._on_consumer_lost)
        self.on_snapshot(self._snapshot)

    # -- fault injection and physical side ----------------------------------------------------

    def blow_fuse(self, pin: int, now: float) -> list[Frame]:
        """The fuse of ``pin`` blows; a HIGH high-side pin goes FAULT and reports it."""
        return self._physical(self.outputs.blow_fuse, check_pin(pin), now)

    def replace_fuse(self, pin: int, now: float) -> list[Frame]:
        """A new fuse: a latched FAULT stays until RESET (KBX §7)."""
        return self._physical(self.outputs.replace_fuse, check_pin(pin), now)

    def set_input(self, pin: int, level: bool, now: float) -> list[Frame]:
        """The external level on ``pin`` (read by 2003h, errata K21)."""
        check_pin(pin)
        check_time("now", now)
        if not isinstance(level, bool):
            raise TypeError(f"level must be a bool, not {type(level).__name__}")
        self.outputs.external[pin - 1] = level
        self._inputs_changed = True
        self._refresh()
        return []

    def _physical(self, action: Any, pin: int, now: float) -> list[Frame]:
        check_time("now", now)
        faults = action(pin)
        self._inputs_changed = True  # a fuse changes what the pin reads
        if not self.powered:
            return []
        self.note_time(now)
        return self._after_outputs_change(faults or [])

    # -- output commands (SDO hooks and RPDO) ----------------------------------------------------

    def _pin_hook(self, pin: int) -> Callable[[int, float], list[Frame]]:
        def on_write(value: int, now: float) -> list[Frame]:
            return self._after_outputs_change(self.outputs.command(pin, value))

        return on_write

    def _on_off_mask(self, value: int, now: float) -> list[Frame]:
        return self._after_outputs_change(self.outputs.command_masks(value, 0))

    def _on_high_mask(self, value: int, now: float) -> list[Frame]:
        return self._after_outputs_change(self.outputs.command_masks(0, value))

    def _on_outputs_pdo(self, data: bytes, now: float) -> list[Frame]:
        # KBX §17: one frame carries both masks; OFF wins (errata K12), so both go at once
        signals = self.description.pdo("outputs").decode(data)
        return self._after_outputs_change(
            self.outputs.command_masks(signals["off"], signals["high"]))

    def _on_pwm(self, value: int, now: float) -> list[Frame] | AbortCode:
        mask, level = split_pwm_register(value)
        if mask & ~PWM_MASK or level > PWM_LEVEL_MAX:  # errata K16
            return AbortCode.INVALID_VALUE
        return self._after_outputs_change(self.outputs.set_pwm(mask, level))

    def _after_outputs_change(self, new_faults: list[int]) -> list[Frame]:
        """Update the objects that read the outputs; report new faults at once (KBX §18)."""
        self._refresh()
        if new_faults and self.pdo_allowed:
            return [self._fault_frame()]
        return []

    def _refresh(self) -> None:
        """Bring the objects that read the outputs (2001h, 2003h, 2008h, 2009h) up to date;
        only what changed is written."""
        outputs, store = self.outputs, self.objects
        states = outputs.state
        if states != self._shown_states:
            for i, state in enumerate(states):
                if state is not self._shown_states[i]:
                    store.set(_PIN_ENTRIES[i], int(state))
            self._shown_states = list(states)
            store.set("output_off_mask", outputs.mask(PinState.OFF))
            store.set("output_high_mask", outputs.mask(PinState.HIGH))
            store.set("output_fault_mask", outputs.mask(PinState.FAULT))
            self._fault_frame_cache = None
            self._inputs_changed = True
        pwm = outputs.pwm_register()
        if pwm != store["pwm"]:
            store.set("pwm", pwm)
        if self._inputs_changed:  # outputs, fuses or external levels moved (errata K21)
            store.set("input_levels", outputs.input_levels())
            self._inputs_changed = False

    def _fault_frame(self) -> Frame:
        """The fault PDO for the present FAULT mask; cached, the periodic message repeats it."""
        frame = self._fault_frame_cache
        layout = self._fault_pdo
        if frame is None or frame.can_id != layout.cob_base + self.node_id:  # cob_id(), inlined
            faults = self.objects.get_int("output_fault_mask")
            frame = Frame(layout.cob_id(self.node_id), layout.encode({"faults": faults}))
            self._fault_frame_cache = frame
        return frame

    # -- restore defaults, consumer heartbeat, periodic faults -------------------------------------

    def _on_consumer_lost(self, now: float) -> None:
        self.outputs.all_off()  # KBX §28 note 2: all outputs off
        self._refresh()

    def _on_fault_period(self, value: int, now: float) -> None:
        self._schedule_faults(value, now)

    def _schedule_faults(self, units: int, now: float) -> None:
        operational = self.nmt_state is NmtState.OPERATIONAL
        self._faults.start(units * FAULT_PERIOD_UNIT_S, now, operational)

    def _periodic_faults(self, now: float) -> list[Frame]:
        return [self._fault_frame()]  # KBX §25 periodic fault message

    # -- CanopenTwin hooks ------------------------------------------------------------------

    def _on_boot(self, now: float, application: bool) -> list[Frame]:
        self.outputs.power_on()  # fail-safe: every reset starts with outputs OFF
        self._refresh()
        self._faults.stop()
        return []

    def _on_state_change(self, previous: NmtState, state: NmtState, now: float) -> list[Frame]:
        if state is NmtState.STOPPED:
            self.outputs.all_off()  # fail-safe (module docstring)
            self._refresh()
        self._schedule_faults(self.objects.get_int("fault_period"), now)
        return []

    def _snapshot(self, now: float) -> dict[str, Any]:
        outputs = self.outputs
        inputs = outputs.input_levels()
        pins = []
        for pin in FACE.pin_numbers:
            in_pwm = outputs.in_pwm(pin)
            pins.append({
                "pin": pin,
                "state": _STATE_NAMES[outputs.state[pin - 1]],
                "fuse": "ok" if outputs.fuse_ok[pin - 1] else "blown",
                "pwm_percent": outputs.pwm_level * 10 if in_pwm else None,
                "input": bool(inputs >> (pin - 1) & 1),
                "low_side": pin in outputs.low_side,
            })
        return {
            "pins": pins,
            "fault_period_ms": self.objects.get_int("fault_period") * 10,
        }
