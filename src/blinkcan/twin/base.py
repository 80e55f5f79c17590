"""What every Blink CANopen twin does the same way: NMT slave, boot-up, heartbeat producer, SDO
server on its object store, RPDOs written into the dictionary, non-volatile settings.

Rule: a twin is a pure state machine. Frames and time (``now``, seconds, monotonic) come in as
arguments; the frames the device would send come back as return values. Nothing here sleeps,
reads a clock or touches a bus. A twin that is powered off, or not addressed, returns ``[]``.

Device twins subclass :class:`CanopenTwin` and add their application behaviour through the
``_on_*`` hooks; they never reimplement NMT, SDO or heartbeat.

Non-volatile memory: a stored setting is written to the NVM before the twin acknowledges it.
When the NVM cannot take it (a file that cannot be written), the SDO write aborts with
0606 0000h "access failed due to a hardware error" and memory is left unchanged, so nothing is
acknowledged that a power cycle would lose. Why 0606 0000h and not 0800 0020h: the request was
valid and the device failed to store it, which is what a failing EEPROM reports; 0800 0020h
"data cannot be transferred or stored" is already this project's answer to a request the device
refuses (a wrong restore signature, errata), and a host should tell the two apart. An NVM file
that turns out corrupt at a reset is refused and kept as found: the twin boots with the settings
it last stored, and every stored write aborts 0606 0000h until a reset finds the file good again
(``snapshot()["nvm_error"]`` says why).
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterable, Mapping
from enum import Enum
from typing import Any

from blinkcan.devices.common import RESTORE_SIGNATURE, ConsumerHeartbeat
from blinkcan.devices.model import DeviceDescription
from blinkcan.devices.objects import Value
from blinkcan.devices.pdo import PdoLayout
from blinkcan.protocol.abort import AbortCode
from blinkcan.protocol.cob import HEARTBEAT, NMT, SDO_RX, SDO_TX, check_node_id, check_time
from blinkcan.protocol.frame import Frame
from blinkcan.protocol.nmt import (
    PDO_ALLOWED,
    SDO_ALLOWED,
    TRANSITIONS,
    NmtAction,
    NmtState,
    heartbeat_frame,
    parse_nmt,
)
from blinkcan.protocol.sdo_server import SdoServer
from blinkcan.twin.dictionary import ObjectStore
from blinkcan.twin.nvm import JsonFileNvm, MemoryNvm, Nvm, NvmError
from blinkcan.twin.schedule import Periodic, milliseconds

_Route = Callable[[Frame, float], list[Frame]]
_new_tuple = tuple.__new__

NMT_STATE_NAMES = {
    NmtState.BOOT_UP: "initialising",
    NmtState.STOPPED: "stopped",
    NmtState.OPERATIONAL: "operational",
    NmtState.PRE_OPERATIONAL: "pre-operational",
}


def open_nvm(nvm: str | os.PathLike[str] | Nvm | None, description: DeviceDescription) -> Nvm:
    if nvm is None:
        return MemoryNvm()
    if isinstance(nvm, (str, os.PathLike)):
        return JsonFileNvm(nvm, description.model, description.generation, description.table)
    return nvm


class ConsumerState(Enum):
    """Heartbeat consumer (KBX §28, PKP rev 1.5 §26): monitoring starts at the first heartbeat."""

    OFF = "off"
    WAITING = "waiting"
    ACTIVE = "active"
    LOST = "lost"


split_consumer_entry = ConsumerHeartbeat.split  # 1016h/01 (errata K8, G4), from devices/


class CanopenTwin:
    """The CANopen side of a Blink device; see the module docstring."""

    def __init__(self, description: DeviceDescription, node_id: int,
                 nvm: str | os.PathLike[str] | Nvm | None = None,
                 settings: Mapping[str, Value] | None = None) -> None:
        check_node_id(node_id)
        self.description = description
        self.factory_node_id = node_id
        self._store = ObjectStore(description.table, node_id)
        configured = self._checked_settings(settings or {})
        self._nvm = open_nvm(nvm, description)  # a file in use by another twin fails here
        try:
            stored = self._nvm.load()  # a corrupt or foreign file fails here, before anything runs
            if stored is None or configured:  # built as configured: as if written earlier
                stored = {**(stored or self._factory_settings()), **configured}
                self._nvm.save(stored)
        except NvmError:
            self._nvm.close()
            raise
        #: why the NVM is refused since the last reset (a corrupt file), or None
        self._nvm_fault: str | None = None
        self._store.load(node_id, stored)
        self._store.persist = self._save_settings
        self._sdo = SdoServer(self._store)
        self._powered = False
        self._nmt = NmtState.BOOT_UP
        self._node_id = self._store.get_int("node_id")
        self._bitrate_code = self._store.get_int("baud_rate")
        self._sdo_tx = SDO_TX + self._node_id
        self._routes: dict[int, _Route] = {}
        self._outbox: list[Frame] = []
        self._after_reply: list[Callable[[float], list[Frame]]] = []
        self._now = 0.0
        self._boot_time = 0.0
        self._heartbeat = Periodic()
        self._store.set_hook("producer_heartbeat_time", self._on_heartbeat_time)
        self._consumer = ConsumerState.OFF
        self._consumer_deadline: float | None = None
        if "consumer_heartbeat_time" in description.table:
            self._store.set_hook("consumer_heartbeat_time", self._on_consumer_time,
                                 check=self._check_consumer_time)
        if "restore_all_parameters" in description.table:
            self._store.set_hook("restore_all_parameters", self._on_restore, keeps_value=False)

    # -- public contract --------------------------------------------------------------------

    @property
    def node_id(self) -> int:
        """The node id in use (a written 2013h/2011h applies at the next reset)."""
        return self._node_id

    @property
    def nmt_state(self) -> NmtState:
        return self._nmt

    @property
    def _nmt(self) -> NmtState:
        return self._nmt_state

    @_nmt.setter
    def _nmt(self, state: NmtState) -> None:
        # the gates are kept as booleans: hashing an enum on every frame costs a Python call
        self._nmt_state = state
        self._sdo_allowed = state in SDO_ALLOWED
        self._pdo_allowed = state in PDO_ALLOWED

    @property
    def powered(self) -> bool:
        return self._powered

    @property
    def listening(self) -> Mapping[int, object]:
        """The standard COB-IDs this twin acts on; a new mapping after every boot."""
        return self._routes

    @property
    def objects(self) -> ObjectStore:
        """The live object dictionary (read it in tests; write through SDO)."""
        return self._store

    @property
    def bitrate(self) -> int:
        """The bit rate in use, from the baud-rate code applied at the last reset."""
        return self.description.bitrates[self._bitrate_code]

    def power_on(self, now: float) -> list[Frame]:
        """Apply power: boot, send the boot-up frame, enter the startup state."""
        check_time("now", now)
        if self._powered:
            return []
        self._powered = True
        return self._boot(now, application=True)

    def close(self) -> None:
        """Release the NVM file (its lock), e.g. before another twin opens it. Stored writes
        abort afterwards; the twin can still run."""
        self._nvm.close()

    def power_off(self) -> None:
        """Remove power: live state is lost, stored settings are kept."""
        self._powered = False
        self._nmt = NmtState.BOOT_UP
        self._routes = {}
        self._heartbeat.stop()
        self._consumer = ConsumerState.OFF
        self._consumer_deadline = None
        self._sdo.reset()
        self._on_power_off()

    def receive(self, frame: Frame, now: float) -> list[Frame]:
        """The frames the device sends in reaction to ``frame`` (often none)."""
        if now - now:  # NaN or infinite (cheaper than math.isfinite on every frame)
            check_time("now", now)
        if not self._powered:
            return []
        if frame.extended:
            return self._on_extended(frame, now)
        route = self._routes.get(frame.can_id)
        if route is None:
            return []
        self._now = now
        return route(frame, now)

    def advance(self, now: float) -> list[Frame]:
        """Frames due by ``now``: heartbeat, periodic PDOs, timeouts. Every deadline
        :meth:`next_deadline` named up to ``now`` is consumed (twin/schedule.py)."""
        if now - now:  # NaN or infinite
            check_time("now", now)
        if not self._powered:
            return []
        self._now = now
        frames: list[Frame] = []
        if self._heartbeat.fire(now):
            frames.append(self._heartbeat_frames[self._nmt])
        deadline = self._consumer_deadline
        if deadline is not None and now >= deadline:
            frames += self._heartbeat_lost(now)
        frames += self._on_advance(now)
        return frames

    def next_deadline(self) -> float | None:
        """When :meth:`advance` next has work, or None."""
        if not self._powered:
            return None
        deadlines = [d for d in self._deadlines() if d is not None]
        if self._heartbeat.due is not None:
            deadlines.append(self._heartbeat.due)
        if self._consumer_deadline is not None:
            deadlines.append(self._consumer_deadline)
        return min(deadlines) if deadlines else None

    def is_sdo_request(self, frame: Frame) -> bool:
        """Whether ``frame`` is an SDO request to this device (the emulator's busy rule)."""
        return not frame.extended and frame.can_id == SDO_RX + self._node_id and self._powered

    def snapshot(self) -> dict[str, Any]:
        """JSON-serialisable state for tests, the CLI and the front panel."""
        return {
            "model": self.description.model,
            "kind": self.description.kind,
            "generation": self.description.generation,
            "quirks": self.description.quirks,
            "powered": self._powered,
            "node_id": self._node_id,
            "nmt_state": NMT_STATE_NAMES[self._nmt] if self._powered else "off",
            "bitrate": self.bitrate,
            "heartbeat_ms": self._store.get_int("producer_heartbeat_time"),
            "settings": self._store.stored_values(),
            **({"nvm_error": self._nvm_fault} if self._nvm_fault else {}),
            **self._consumer_snapshot(),
            **self._snapshot(),
        }

    # -- boot and NMT -----------------------------------------------------------------------

    def _checked_settings(self, settings: Mapping[str, Value]) -> dict[str, Value]:
        """Stored settings a twin is built with (as if configured earlier), by object name;
        ValueError for a name that is not a stored setting or a value out of its range."""
        table = self.description.table
        stored_names = sorted(entry.name for entry in table if entry.stored)
        checked: dict[str, Value] = {}
        for name, value in settings.items():
            if name not in stored_names:
                raise ValueError(f"{name!r} is not a stored setting of this "
                                 f"{self.description.kind}; stored settings: "
                                 f"{', '.join(stored_names)}")
            entry = table[name]
            if not entry.accepts(value):
                raise ValueError(f"{name} takes {entry.describe_valid()}, not {value!r}")
            checked[name] = value
        return checked

    def _factory_settings(self) -> dict[str, Value]:
        return {
            entry.name: entry.default_for(self.factory_node_id)
            for entry in self.description.table
            if entry.stored
        }

    def _save_settings(self, settings: dict[str, Value]) -> AbortCode | None:
        """Write ``settings`` to the NVM; 0606 0000h if it cannot (see the module docstring)."""
        if self._nvm_fault is not None:
            return AbortCode.HARDWARE_ERROR
        try:
            self._nvm.save(settings)
        except (NvmError, OSError):
            return AbortCode.HARDWARE_ERROR
        return None

    def _persist(self) -> AbortCode | None:
        return self._save_settings(self._store.stored_values())

    def _stored_settings(self) -> dict[str, Value] | None:
        """The stored settings to boot with: the NVM's; if it cannot be read now, the ones
        last stored, and the NVM is refused until a reset reads it again (never replaced)."""
        try:
            stored = self._nvm.load()
        except NvmError as error:
            self._nvm_fault = str(error)
            return self._store.stored_values()
        self._nvm_fault = None
        return stored

    def _restore_factory_settings(self) -> AbortCode | None:
        """Stored settings back to factory values; they take effect at the next reset, and
        reads return them already (errata: "a read returns the stored value"). Nothing
        changes if the NVM cannot take them."""
        factory = self._factory_settings()
        refusal = self._save_settings(factory)
        if refusal is None:
            for name, value in factory.items():
                self._store.set(name, value)
        return refusal

    def _boot(self, now: float, application: bool) -> list[Frame]:
        """Power-on or reset: CiA 301 initialisation, then the boot-up frame and pre-operational."""
        if application:  # reset node / power-on: node id, bit rate and live values re-applied
            self._store.load(self.factory_node_id, self._stored_settings())
            self._node_id = self._store.get_int("node_id")
            self._bitrate_code = self._store.get_int("baud_rate")
        self._sdo.reset()
        self._sdo_tx = SDO_TX + self._node_id
        self._heartbeat_frames = {state: heartbeat_frame(self._node_id, state)
                                  for state in NmtState}
        self._routes = self._build_routes()
        self._nmt = NmtState.PRE_OPERATIONAL
        self._boot_time = now
        self._now = now
        frames: list[Frame] = []
        if self._store.get_int("boot_up_service"):  # PKP §8/§20, KBX §15/§27
            frames.append(heartbeat_frame(self._node_id, NmtState.BOOT_UP))
        # PKP §25: "the boot-up message is regarded as first heartbeat message"
        self._schedule_heartbeat(self._store.get_int("producer_heartbeat_time"), now)
        self._start_consumer()
        frames += self._on_boot(now, application)
        if self._store.get_int("active_on_startup"):  # PKP §21, KBX §26
            frames += self._enter(NmtState.OPERATIONAL, now)
        return frames

    def _build_routes(self) -> dict[int, _Route]:
        routes: dict[int, _Route] = {NMT: self._on_nmt, SDO_RX + self._node_id: self._on_sdo}
        for layout in self.description.rx_pdos:
            routes[layout.cob_id(self._node_id)] = self._rpdo_route(layout)
        if "consumer_heartbeat_time" in self.description.table:
            period, node, _ = split_consumer_entry(self._store.get_int("consumer_heartbeat_time"))
            if period:
                routes[HEARTBEAT + node] = self._on_heartbeat
        return routes

    def _on_nmt(self, frame: Frame, now: float) -> list[Frame]:
        request = parse_nmt(frame, self.description.nmt_aliases)
        if request is None or request.node_id not in (0, self._node_id):
            return []
        next_state, action = TRANSITIONS[self._nmt, request.command]
        if action is NmtAction.RESET_NODE:
            self._on_power_off()
            return self._boot(now, application=True)
        if action is NmtAction.RESET_COMMUNICATION:
            return self._boot(now, application=False)
        return self._enter(next_state, now)

    def _enter(self, state: NmtState, now: float) -> list[Frame]:
        previous, self._nmt = self._nmt, state
        if previous is state:
            return []
        return self._on_state_change(previous, state, now)

    # -- SDO ----------------------------------------------------------------------------------

    def _on_sdo(self, frame: Frame, now: float) -> list[Frame]:
        if not self._sdo_allowed:  # no SDO while stopped (CiA 301 table 84)
            return []
        reply = self._sdo.on_request(frame.data)
        if reply is None:
            return []
        frames = [_new_tuple(Frame, (self._sdo_tx, reply, False))]  # Frame.trusted, inlined
        if self._outbox:
            frames += self._outbox
            self._outbox = []
        if self._after_reply:
            actions, self._after_reply = self._after_reply, []
            for action in actions:
                frames += action(now)
        return frames

    def _on_heartbeat_time(self, value: int) -> AbortCode | None:
        self._schedule_heartbeat(value, self._now)
        return None

    def _schedule_heartbeat(self, period_ms: int, now: float) -> None:
        """The running period is kept apart from the stored value, which may change (restore
        defaults) without taking effect until the next reset."""
        self._heartbeat.start(now, milliseconds(period_ms))

    # -- consumer heartbeat and restore defaults (KBX §28/§36, PKP rev 1.5 §26/§34) ----------

    def _check_consumer_time(self, value: int) -> AbortCode | None:
        rule = self.description.consumer_heartbeat
        if rule is None or not rule.accepts(value, self._node_id):
            return AbortCode.INVALID_VALUE  # errata K8, G4
        return None

    def _on_consumer_time(self, value: int) -> AbortCode | None:
        self._store.set("consumer_heartbeat_time", value)
        self._start_consumer()
        self._routes = self._build_routes()  # listen to the newly monitored node
        return None

    def _start_consumer(self) -> None:
        self._consumer, self._consumer_deadline = ConsumerState.OFF, None
        if "consumer_heartbeat_time" in self.description.table:
            period, _, _ = split_consumer_entry(self._store.get_int("consumer_heartbeat_time"))
            if period:
                self._consumer = ConsumerState.WAITING

    def _on_heartbeat(self, frame: Frame, now: float) -> list[Frame]:
        if self._consumer is ConsumerState.OFF or not frame.data:
            return []
        period, _, _ = split_consumer_entry(self._store.get_int("consumer_heartbeat_time"))
        self._consumer = ConsumerState.ACTIVE
        self._consumer_deadline = now + period / 1000
        return []

    def _heartbeat_lost(self, now: float) -> list[Frame]:
        # KBX §28 / PKP rev 1.5 §26 note 2: switch off, pre-operational until an NMT start,
        # even if the producer comes back
        self._consumer = ConsumerState.LOST
        self._consumer_deadline = None
        self._on_consumer_lost(now)
        return self._enter(NmtState.PRE_OPERATIONAL, now)

    def _consumer_snapshot(self) -> dict[str, Any]:
        if "consumer_heartbeat_time" not in self.description.table:
            return {}
        period, node, _ = split_consumer_entry(self._store.get_int("consumer_heartbeat_time"))
        return {"heartbeat_consumer": {"node_id": node, "time_ms": period,
                                       "state": self._consumer.value}}

    def _on_restore(self, value: int) -> AbortCode | None:
        if value != RESTORE_SIGNATURE:  # errata: a wrong signature aborts 0800 0020h
            return AbortCode.CANNOT_TRANSFER
        return self._restore_factory_settings()  # applied at the next reset (errata K18, G5)

    def _on_consumer_lost(self, now: float) -> None:
        """What the device switches off when the watched heartbeat is lost."""

    # -- PDO ----------------------------------------------------------------------------------

    def _rpdo_route(self, layout: PdoLayout) -> _Route:
        def route(frame: Frame, now: float) -> list[Frame]:
            if not self._pdo_allowed or len(frame.data) < layout.min_length:
                return []
            return self._on_rpdo(layout, layout.decode(frame.data), now)

        return route

    def _on_rpdo(self, layout: PdoLayout, signals: dict[str, int], now: float) -> list[Frame]:
        """Write an RPDO's signals into the dictionary as SDO writes would, hooks included.
        A frame with any value out of range is ignored whole (errata P15)."""
        table = self.description.table
        mapped = [(table[s.entry], signals[s.name]) for s in layout.signals if s.entry]
        if not all(entry.accepts(value) for entry, value in mapped):
            return []
        for entry, value in mapped:
            if self._store.write_from_pdo(entry.name, value) is not None:
                return []
        frames, self._outbox = self._outbox, []
        return frames

    # -- hooks for device twins -----------------------------------------------------------------

    def _on_boot(self, now: float, application: bool) -> list[Frame]:
        return []

    def _on_power_off(self) -> None:
        """Live application state is lost (power off or reset node)."""

    def _on_state_change(self, previous: NmtState, state: NmtState, now: float) -> list[Frame]:
        return []

    def _on_advance(self, now: float) -> list[Frame]:
        return []

    def _deadlines(self) -> Iterable[float | None]:
        return ()

    def _on_extended(self, frame: Frame, now: float) -> list[Frame]:
        return []

    def _snapshot(self) -> dict[str, Any]:
        return {}
