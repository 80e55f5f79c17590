"""What every Blink CANopen twin does the same way: NMT slave, boot-up, heartbeat producer, SDO
server on its object store, RPDOs written into the dictionary, non-volatile settings.

Rule: a twin is a pure state machine. Frames and time (``now``, seconds, monotonic) come in as
arguments; the frames the device would send come back as return values. Nothing here sleeps,
reads a clock or touches a bus. A twin that is powered off, or not addressed, returns ``[]``.

A model's behaviour plugs in through public hooks registered with the twin (``on_write``,
``on_rpdo``, ``on_boot``, ``add_timer``, ...; the shapes are in :mod:`blinkcan.twin.hooks`): each
gets what it acts on and ``now`` and returns the frames the device sends (or an abort code). It
never reimplements NMT, SDO or heartbeat, and never reads this class's private state. The node id
in use is held once; the SDO reply COB-ID, the heartbeat frames and the routes follow it.

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

import math
import operator
from collections.abc import Callable, Mapping
from enum import Enum
from fractions import Fraction
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
from blinkcan.twin.hooks import (
    Action,
    BootHook,
    DeadlineSource,
    ExtraSettings,
    FrameHook,
    RpdoHook,
    SnapshotHook,
    StateHook,
    Watcher,
    WriteHook,
)
from blinkcan.twin.nvm import NvmArgument, NvmError, open_nvm
from blinkcan.twin.schedule import Periodic, Ticker, milliseconds

_Route = Callable[[Frame, float], list[Frame]]
_new_tuple = tuple.__new__

NMT_STATE_NAMES = {
    NmtState.BOOT_UP: "initialising",
    NmtState.STOPPED: "stopped",
    NmtState.OPERATIONAL: "operational",
    NmtState.PRE_OPERATIONAL: "pre-operational",
}


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
                 nvm: NvmArgument = None,
                 settings: Mapping[str, Value] | None = None,
                 extra_settings: ExtraSettings | None = None) -> None:
        check_node_id(node_id)
        self.description = description
        self.factory_node_id = node_id
        self._store = ObjectStore(description.table, node_id)
        configured = self._checked_settings(settings or {})
        #: settings kept in the NVM beside the objects' (saved along with every write)
        self._extra_settings = extra_settings
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
        #: the heartbeat frame of each NMT state, and of the present one (both follow the node id
        #: in use: _use_node_id)
        self._heartbeat_frames = {state: heartbeat_frame(node_id, state) for state in NmtState}
        self._nmt = NmtState.BOOT_UP
        self._bitrate_code = self._store.get_int("baud_rate")
        # registered behaviour (see blinkcan.twin.hooks)
        self._rpdo_hooks: dict[str, RpdoHook] = {}
        self._frame_hooks: dict[int, FrameHook] = {}
        self._boot_hooks: list[BootHook] = []
        self._power_off_hooks: list[Callable[[], None]] = []
        self._state_hooks: list[StateHook] = []
        self._consumer_lost_hooks: list[Callable[[float], None]] = []
        self._advance_hooks: list[Action] = []
        self._timers: list[Periodic] = []
        self._deadline_sources: list[DeadlineSource] = []
        self._snapshot_hooks: list[SnapshotHook] = []
        self._extended_hook: FrameHook | None = None
        self._reply_filter: Callable[[bytes], bytes] | None = None
        self._watcher: Watcher | None = None
        self._routes: dict[int, _Route] = {}
        self._outbox: list[Frame] = []
        self._after_reply: list[Action] = []
        self._now = 0.0
        self._boot_time = 0.0
        self._heartbeat = Ticker()
        self._use_node_id(self._store.get_int("node_id"))
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
        return self._nmt_state  # not through _nmt: behaviour hooks read this on every write

    @property
    def _nmt(self) -> NmtState:
        return self._nmt_state

    @_nmt.setter
    def _nmt(self, state: NmtState) -> None:
        # the gates are kept as booleans: hashing an enum on every frame costs a Python call
        self._nmt_state = state
        self._heartbeat_frame = self._heartbeat_frames[state]
        self._sdo_allowed = state in SDO_ALLOWED
        self._pdo_allowed = state in PDO_ALLOWED

    @property
    def pdo_allowed(self) -> bool:
        """Whether the NMT state lets PDOs through (operational, CiA 301 table 84)."""
        return self._pdo_allowed

    @property
    def powered(self) -> bool:
        return self._powered

    @property
    def boot_time(self) -> float:
        """When the device last booted (power-on or reset)."""
        return self._boot_time

    def steps_since_boot(self, now: float, period: float, width: int) -> int:
        """Whole ``period`` s steps from the last boot to ``now`` on a ``width``-bit counter
        that wraps (the key PDO's tick timer: PKP rev 1.5 §11 note, errata P8). Any finite
        ``now`` gives a count, an absurd one too: where the quotient overflows a float, the
        steps are counted exactly (a pure twin never crashes on a finite time); a time that is
        no number of seconds (inf, nan) is refused with ValueError."""
        steps = (check_time("now", now) - self._boot_time) / period
        if math.isfinite(steps):
            return int(steps) % (1 << width)
        exact = (Fraction(now) - Fraction(self._boot_time)) / Fraction(period)
        return int(exact) % (1 << width)

    @property
    def last_time(self) -> float:
        """The time of the last input (frame, advance, physical action): what snapshot()
        describes."""
        return self._now

    #: The standard COB-IDs this twin acts on (a Mapping[int, object]); a new mapping after
    #: every boot. A C-level getter: the emulator asks after every frame a twin hears
    listening = property(operator.attrgetter("_routes"),
                         doc="The standard COB-IDs this twin acts on; a new mapping after "
                             "every boot.")

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
        self._lose_live_state()

    def receive(self, frame: Frame, now: float) -> list[Frame]:
        """The frames the device sends in reaction to ``frame`` (often none)."""
        if now - now:  # NaN or infinite (cheaper than math.isfinite on every frame)
            check_time("now", now)
        if not self._powered:
            return []
        if frame.extended:
            hook = self._extended_hook
            return [] if hook is None else hook(frame, now)
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
        heartbeat = self._heartbeat
        due = heartbeat.due
        if due is not None and now >= due:
            owed = heartbeat.fire(now)
            frames = [self._heartbeat_frame] if owed == 1 else [self._heartbeat_frame] * owed
        else:
            frames = []
        deadline = self._consumer_deadline
        if deadline is not None and now >= deadline:
            frames += self._heartbeat_lost(now)
        for hook in self._advance_hooks:
            frames += hook(now)
        for timer in self._timers:
            due = timer.due
            if due is not None and now >= due:
                frames += timer.advance(now)
        return frames

    def next_deadline(self) -> float | None:
        """When :meth:`advance` next has work, or None."""
        # the emulator asks after every call: no lists on the way
        if not self._powered:
            return None
        best = self._heartbeat.due
        deadline = self._consumer_deadline
        if deadline is not None and (best is None or deadline < best):
            best = deadline
        for timer in self._timers:
            deadline = timer.due
            if deadline is not None and (best is None or deadline < best):
                best = deadline
        for source in self._deadline_sources:
            for deadline in source(self._now):
                if deadline is not None and (best is None or deadline < best):
                    best = deadline
        return best

    def is_sdo_request(self, frame: Frame) -> bool:
        """Whether ``frame`` is an SDO request to this device (the emulator's busy rule)."""
        return not frame.extended and frame.can_id == SDO_RX + self._node_id and self._powered

    def snapshot(self) -> dict[str, Any]:
        """JSON-serialisable state for tests, the CLI and the front panel."""
        extra: dict[str, Any] = {}
        for hook in self._snapshot_hooks:
            extra.update(hook(self._now))
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
            **extra,
        }

    # -- registering a model's behaviour (blinkcan.twin.hooks) ----------------------------------

    def on_write(self, name: str, hook: WriteHook, keeps_value: bool = True,
                 check: Callable[[Any], AbortCode | None] | None = None) -> None:
        """Run ``hook(value, now)`` on every write of object ``name`` (SDO or RPDO), before the
        value is stored: it returns the frames to send after the reply, an abort code to refuse
        the value, or None. With ``keeps_value=False`` the value is a command, not the entry's
        new value (the hook updates the objects itself). ``check`` refuses a value before
        anything happens, the NVM write included."""

        def store_hook(value: Any) -> AbortCode | None:
            result = hook(value, self._now)
            if result is None:
                return None
            if result.__class__ is list:
                self._outbox += result
                return None
            return result  # type: ignore[return-value]

        self._store.set_hook(name, store_hook, keeps_value, check)

    def on_rpdo(self, name: str, hook: RpdoHook) -> None:
        """Run ``hook(data, now)`` for RPDO ``name`` (a layout of the description) instead of
        writing its signals into the objects; only while PDOs are allowed and the frame is long
        enough (errata P14)."""
        self._rpdo_hooks[name] = hook

    def on_frame(self, can_id: int, hook: FrameHook) -> None:
        """Act on ``can_id`` too (e.g. SYNC), from the next boot on, while CANopen runs."""
        self._frame_hooks[can_id] = hook

    def on_extended(self, hook: FrameHook) -> None:
        """Run ``hook(frame, now)`` for every 29-bit frame while powered (another protocol)."""
        self._extended_hook = hook

    def on_boot(self, hook: BootHook) -> None:
        """Run ``hook(now, application)`` at every boot, before the startup state is entered."""
        self._boot_hooks.append(hook)

    def on_power_off(self, hook: Callable[[], None]) -> None:
        """Run ``hook()`` when live state is lost (power off, reset node)."""
        self._power_off_hooks.append(hook)

    def on_state_change(self, hook: StateHook) -> None:
        """Run ``hook(previous, state, now)`` when the NMT state changes."""
        self._state_hooks.append(hook)

    def on_consumer_lost(self, hook: Callable[[float], None]) -> None:
        """Run ``hook(now)`` when the watched heartbeat is lost: what the device switches off."""
        self._consumer_lost_hooks.append(hook)

    def on_advance(self, hook: Action) -> None:
        """Run ``hook(now)`` at every :meth:`advance`, after the heartbeat, before the timers."""
        self._advance_hooks.append(hook)

    def add_timer(self, produce: Action) -> Periodic:
        """A periodic producer of ``produce(now)``; start and stop it with the returned
        :class:`~blinkcan.twin.schedule.Periodic`. Every timer stops when the device loses power."""
        timer = Periodic(produce)
        self._timers.append(timer)
        return timer

    def add_deadlines(self, source: DeadlineSource) -> None:
        """Times besides the timers' at which :meth:`advance` has work (a show's next step)."""
        self._deadline_sources.append(source)

    def on_snapshot(self, hook: SnapshotHook) -> None:
        """Entries ``hook(now)`` adds to :meth:`snapshot`."""
        self._snapshot_hooks.append(hook)

    def filter_sdo_replies(self, rewrite: Callable[[bytes], bytes]) -> None:
        """Pass every SDO reply through ``rewrite`` (a firmware's own abort codes)."""
        self._reply_filter = rewrite

    def watch_frames(self, watcher: Watcher | None) -> None:
        """Show ``watcher(frame, now)`` every routed frame before it is acted on, until
        ``watch_frames(None)`` or the loss of live state (DEMO mode is left by another
        command, PKP §24)."""
        self._watcher = watcher
        self._routes = self._build_routes()

    # -- what a behaviour may do ----------------------------------------------------------------

    def note_time(self, now: float) -> None:
        """A physical input (a key, a knob) happened at ``now``."""
        self._now = now

    def after_reply(self, action: Action) -> None:
        """Run ``action(now)`` once the present SDO reply is sent (a reboot the reply must
        precede, errata P10)."""
        self._after_reply.append(action)

    def use_node_id(self, node_id: int) -> None:
        """Use ``node_id`` from now on (errata G1): the SDO reply COB-ID, the heartbeat frames
        and the routes follow it."""
        self._use_node_id(check_node_id(node_id))
        self._routes = self._build_routes()

    def reset_node(self, now: float) -> list[Frame]:
        """Reset node: live state lost, boot as at power-on (CiA 301)."""
        check_time("now", now)
        self._lose_live_state()
        return self._boot(now, application=True)

    def silence(self) -> None:
        """CANopen says nothing until the next boot (the device speaks another protocol, J-1):
        no routes, no heartbeat, no timers, NMT initialising."""
        self._routes = {}
        self._nmt = NmtState.BOOT_UP
        self._heartbeat.stop()
        for timer in self._timers:
            timer.stop()

    def stored_settings(self) -> dict[str, Value]:
        """The settings in the NVM now (what the next boot uses), extras included."""
        return self._stored_settings() or {}

    def save_settings(self, extras: Mapping[str, Value] | None = None) -> AbortCode | None:
        """Store the objects' settings (with ``extras`` instead of the registered extra
        settings, if given); 0606 0000h if the NVM cannot take them."""
        settings = self._store.stored_values()
        if extras is None:
            return self._save_settings(settings)
        return self._write_nvm({**settings, **extras})

    def restore_factory_settings(self) -> AbortCode | None:
        """Stored settings back to factory values; they take effect at the next reset, and
        reads return them already (errata: "a read returns the stored value"). Nothing
        changes if the NVM cannot take them."""
        factory = self._factory_settings()
        refusal = self._save_settings(factory)
        if refusal is None:
            for name, value in factory.items():
                self._store.set(name, value)
        return refusal

    # -- boot and NMT -----------------------------------------------------------------------

    def _use_node_id(self, node_id: int) -> None:
        """The one place the node id in use is set; what derives from it follows."""
        self._node_id = node_id
        self._sdo_tx = SDO_TX + node_id
        self._heartbeat_frames = {state: heartbeat_frame(node_id, state) for state in NmtState}
        self._heartbeat_frame = self._heartbeat_frames[self._nmt_state]

    def _lose_live_state(self) -> None:
        self._watcher = None
        for timer in self._timers:
            timer.stop()
        for hook in self._power_off_hooks:
            hook()

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
        """Write ``settings`` (and the extra settings) to the NVM; 0606 0000h if it cannot
        (see the module docstring)."""
        extras = self._extra_settings
        return self._write_nvm(settings if extras is None else {**settings, **extras()})

    def _write_nvm(self, settings: dict[str, Value]) -> AbortCode | None:
        if self._nvm_fault is not None:
            return AbortCode.HARDWARE_ERROR
        try:
            self._nvm.save(settings)
        except (NvmError, OSError):
            return AbortCode.HARDWARE_ERROR
        return None

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

    def _boot(self, now: float, application: bool) -> list[Frame]:
        """Power-on or reset: CiA 301 initialisation, then the boot-up frame and pre-operational."""
        if application:  # reset node / power-on: node id, bit rate and live values re-applied
            self._store.load(self.factory_node_id, self._stored_settings())
            self._use_node_id(self._store.get_int("node_id"))
            self._bitrate_code = self._store.get_int("baud_rate")
        self._sdo.reset()
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
        for hook in self._boot_hooks:
            frames += hook(now, application)
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
        routes.update(self._frame_hooks)
        watcher = self._watcher
        if watcher is None:
            return routes
        # only while a watcher is set do the routes carry it, so normal traffic pays nothing
        return {can_id: _watched(watcher, route) for can_id, route in routes.items()}

    def _on_nmt(self, frame: Frame, now: float) -> list[Frame]:
        request = parse_nmt(frame, self.description.nmt_aliases)
        if request is None or request.node_id not in (0, self._node_id):
            return []
        next_state, action = TRANSITIONS[self._nmt, request.command]
        if action is NmtAction.RESET_NODE:
            return self.reset_node(now)
        if action is NmtAction.RESET_COMMUNICATION:
            return self._boot(now, application=False)
        return self._enter(next_state, now)

    def _enter(self, state: NmtState, now: float) -> list[Frame]:
        previous, self._nmt = self._nmt, state
        if previous is state:
            return []
        frames: list[Frame] = []
        for hook in self._state_hooks:
            frames += hook(previous, state, now)
        return frames

    # -- SDO ----------------------------------------------------------------------------------

    def _on_sdo(self, frame: Frame, now: float) -> list[Frame]:
        if not self._sdo_allowed:  # no SDO while stopped (CiA 301 table 84)
            return []
        reply = self._sdo.on_request(frame.data)
        if reply is None:
            return []
        if self._reply_filter is not None:
            reply = self._reply_filter(reply)
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
        self._heartbeat.run(now, milliseconds(period_ms))

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
        for hook in self._consumer_lost_hooks:
            hook(now)
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
        return self.restore_factory_settings()  # applied at the next reset (errata K18, G5)

    # -- PDO ----------------------------------------------------------------------------------

    def _rpdo_route(self, layout: PdoLayout) -> _Route:
        hook = self._rpdo_hooks.get(layout.name)
        if hook is not None:
            def hooked(frame: Frame, now: float) -> list[Frame]:
                if not self._pdo_allowed or len(frame.data) < layout.min_length:
                    return []
                return hook(frame.data, now)

            return hooked

        def route(frame: Frame, now: float) -> list[Frame]:
            if not self._pdo_allowed or len(frame.data) < layout.min_length:
                return []
            return self._write_rpdo(layout, layout.decode(frame.data))

        return route

    def _write_rpdo(self, layout: PdoLayout, signals: dict[str, int]) -> list[Frame]:
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


def _watched(watcher: Watcher, route: _Route) -> _Route:
    def watch_then_route(frame: Frame, now: float) -> list[Frame]:
        watcher(frame, now)
        return route(frame, now)

    return watch_then_route
