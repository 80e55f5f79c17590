"""What every host driver does the same way, read from the device's object table.

Objects are named as in ``devices/`` (``driver.read("producer_heartbeat_time")``); a value is
checked against the table before anything is sent, so a bad argument raises ``ValueError``
naming the valid range and the bus sees nothing.

Before its first command a driver confirms which device answers at its node id (1000h device
type, 1018h/01 vendor, 100Bh model, compared with its description in ``devices/``) and refuses
any other with :class:`WrongDeviceError` (:class:`NoDeviceError` when nothing answers):
a keypad driver pointed at a Keybox would otherwise switch its outputs with LED PDOs (both
listen on 200h + node id). ``verify=False`` skips this for devices that cannot answer SDO.
Two devices at one node id (a wiring mistake, two emulators) answer each request twice, so a
reply for another object or one nobody awaited makes the check count the answers to one read:
more than one is :class:`SharedNodeIdError` ("two devices answer at node 15h").

Health (:class:`HealthEvent`) follows what the device reports in its heartbeat, and the NMT
commands sent to it (by this driver or heard from another master on 000h):

- "boot-up": it (re)booted; "state": it reported an NMT state other than the last one;
- "lost" / "back": its heartbeat stopped / was heard again (after :meth:`monitor_heartbeat`);
- "watchdog": it went from operational to pre-operational with no NMT command asking for
  that: its consumer heartbeat (1016h) missed the host's, and it switched its outputs (Keybox,
  KBX §28) or LEDs (keypad generation 2, rev 1.5 §26) off. :meth:`watch_host` turns the
  device's own heartbeat on (1017h, if it was off) so that the driver sees this.

A heartbeat answers an NMT command only if it can come after it: the states commands asked for
are kept until a heartbeat reports them, so a heartbeat sent just before a command (still on
the wire when it went out) is never taken for its answer, nor for a trip.

A driver class (``Keypad``, ``Keybox``, a new model's) builds on :class:`Device` through its
public face only: :meth:`Device.listen` and :meth:`Device.on_close` for the frames it hears,
:meth:`Device.pdo_frame` for the PDOs it sends, :func:`confirm_or_close` in its constructor,
:attr:`Device.health_id`, :meth:`Device.heard`, and the hooks it overrides (called on the bus
thread; applications do not call them): :meth:`Device.nmt_command_seen`,
:meth:`Device.state_reported`, :meth:`Device.booted_up`, :meth:`Device.watchdog_tripped`,
:meth:`Device.host_heartbeat_sent` and :meth:`Device.adopt_identity`.
"""

from __future__ import annotations

import functools
import math
import threading
from collections.abc import Callable, Iterable, Iterator, Mapping
from dataclasses import dataclass
from typing import Any

import can

from blinkcan.devices.common import RESTORE_SIGNATURE
from blinkcan.devices.model import DeviceDescription
from blinkcan.devices.objects import ObjectEntry, Ranges, Value
from blinkcan.devices.registry import identify
from blinkcan.host.bus import Handler, HostBus, Timer
from blinkcan.host.events import EventSource
from blinkcan.host.identity_errors import IdentityError, SharedNodeIdError, several_answer
from blinkcan.host.sdo import SdoClient, check_retries
from blinkcan.host.waits import check_wait
from blinkcan.protocol.cob import HEARTBEAT, NMT, check_node_id, check_range, check_time
from blinkcan.protocol.frame import Frame
from blinkcan.protocol.nmt import NmtCommand, NmtState, nmt_frame, parse_nmt
from blinkcan.protocol.sdo_client import SdoAbortError, SdoProtocolError, SdoTimeoutError
from blinkcan.runtime.port import Port

BOOT_UP, STATE, LOST, BACK, WATCHDOG = "boot-up", "state", "lost", "back", "watchdog"
#: the state an NMT command asks for (CiA 301 NMT state machine); resets answer with a boot-up
_ASKED_KEPT = 8  # NMT commands remembered until a heartbeat reports what they asked for
_ASKED = {NmtCommand.START: NmtState.OPERATIONAL, NmtCommand.STOP: NmtState.STOPPED,
          NmtCommand.ENTER_PRE_OPERATIONAL: NmtState.PRE_OPERATIONAL}
#: what a driver compares to confirm the device: 1000h, 1018h/01, 100Bh (PKP §26/§31/§32,
#: KBX §30/§35/§37); the values come from the description in devices/
IDENTITY_ENTRIES = ("device_type", "vendor_id", "model_id")


def unreversed(version: str) -> str:
    """errata P5/P6: some firmware sends "10_V" for "V_01" and "2.2V" for "V2.2"; a value that
    ends in V and reads right reversed is reversed."""
    if version.endswith("V") and not version.startswith("V"):
        return version[::-1]
    return version


def in_units(what: str, period: float, unit_s: float) -> int | None:
    """``period`` seconds as a whole number of ``unit_s`` units, once checked as a number of
    seconds (finite, not a bool: ``what`` names it in the TypeError/ValueError); None for a
    period no integer of units holds (1e308 s in milliseconds is infinite)."""
    units = check_time(what, period) / unit_s
    return round(units) if math.isfinite(units) else None


def milliseconds(what: str, period: float) -> int:
    """``period`` seconds as whole milliseconds, once checked as a number of seconds (finite,
    not a bool: ``what`` names it in the TypeError/ValueError; one too long for any timer is a
    ValueError too)."""
    ms = in_units(what, period, 0.001)
    if ms is None:
        raise ValueError(f"{what} must be a number of seconds a timer holds, not {period!r}")
    return ms


def check_watchdog(period: float) -> int:
    """The host heartbeat ``period`` of a watchdog, in ms, if the device can watch it (its
    consumer time, twice the period, fits 1016h: KBX §28 note 1); else TypeError/ValueError,
    before anything is sent."""
    return check_range("watchdog period in ms", milliseconds("watchdog period", period), 10,
                       0xFEFF // 2)


def seconds_spans(spans: Iterable[tuple[int, int]], unit_s: float) -> str:
    """Valid counts of ``unit_s`` units as seconds: "0 or 0.01..65.279"."""
    return " or ".join(f"{lo * unit_s:g}" if lo == hi else f"{lo * unit_s:g}..{hi * unit_s:g}"
                       for lo, hi in spans)


@dataclass(frozen=True)
class Identity:
    node_id: int
    model: str  # the registered model, as its description names it (what --model takes)
    device_type: int
    vendor_id: int
    device_name: str
    model_id: str
    hardware_version: str
    software_version: str
    serial_number: str | None = None  # the keypad's 2200h; the Keybox documents none


class WrongDeviceError(IdentityError):
    """Another kind of device answered at the node id; the message names it."""


class NoDeviceError(IdentityError):
    """Nothing answered the identity reads at the node id."""


def runs_in_simulated_time(bus: object) -> bool:
    """Whether ``bus`` (a python-can bus, a ``HostBus`` or a port) runs in simulated time: its
    scheduler says so (a simulated bus's, a rig's, is the simulation's; a python-can bus of
    an adapter has none)."""
    return bool(getattr(getattr(bus, "scheduler", None), "simulated", False))


@dataclass(frozen=True)
class _BusTime:
    """What :func:`check_wait` asks of a bus not attached yet: whether it is simulated."""

    simulated: bool


def confirm_or_close(device: Device, verify: bool) -> None:
    """A driver's constructor: :meth:`Device.confirm` the device (when ``verify``; without, the
    application vouches for it); on failure the driver lets go of the bus and the error
    rises."""
    if not verify:
        device.confirmed = True
        return
    try:
        device.confirm()
    except BaseException:
        device.close()
        raise


def check_one_device(sdo: SdoClient, window: float | None = None) -> None:
    """:class:`SharedNodeIdError` when more than one device answers a read of 1000h (every
    CANopen device has it, CiA 301 §7.5.2.1) at ``sdo``'s node within ``window`` seconds
    (default: the client's timeout)."""
    replies = sdo.channel.answers(0x1000, 0, sdo.timeout if window is None else window)
    if len(replies) > 1:
        raise SharedNodeIdError(several_answer(len(replies), sdo.node_id), len(replies))


@dataclass(frozen=True)
class HealthEvent:
    """``kind``: "boot-up", "state" (a newly reported NMT ``state``), "lost" (heartbeat
    missed), "back" (heard again) or "watchdog" (the device's consumer heartbeat tripped: it
    went pre-operational by itself and switched its outputs or LEDs off)."""

    node_id: int
    kind: str
    time: float
    state: NmtState | None = None


class Device:
    """A Blink CANopen device seen from the controller."""

    def __init_subclass__(cls, **options: Any) -> None:
        """A driver class's constructor lets go of the bus when it fails once
        :meth:`Device.__init__` attached it (a check, a confirmation, a J1939 link): a
        failed driver leaves no reader nor subscription behind, whatever raised."""
        super().__init_subclass__(**options)
        init = cls.__dict__.get("__init__")
        if init is None:
            return

        @functools.wraps(init)
        def closing_on_failure(self: Device, *args: Any, **kwargs: Any) -> None:
            try:
                init(self, *args, **kwargs)
            except BaseException:
                if "_unsubscribe" in vars(self):  # Device.__init__ attached the bus
                    self.close()
                raise

        cls.__init__ = closing_on_failure  # type: ignore[method-assign]

    def __init__(self, bus: HostBus | can.BusABC, node_id: int, description: DeviceDescription,
                 *, sdo_timeout: float = 0.5, sdo_retries: int = 1) -> None:
        """Set up; a subclass calls :meth:`confirm` (unless told not to) before any command.
        Every argument is checked before the bus is attached (TypeError/ValueError naming
        the valid values): a bad one leaves nothing behind and sends nothing."""
        self.node_id = check_node_id(node_id)
        if not isinstance(description, DeviceDescription):
            raise TypeError("description must be a DeviceDescription (blinkcan.devices), not "
                            f"{type(description).__name__}")
        if not isinstance(bus, (HostBus, can.BusABC, Port)):
            raise TypeError("bus must be a python-can bus, a HostBus or a Port, not "
                            f"{type(bus).__name__}")
        # a simulated bus's bound too (the rig's virtual seconds)
        check_wait("sdo_timeout", sdo_timeout, _BusTime(runs_in_simulated_time(bus)))
        check_retries(sdo_retries)
        self.description = description
        self.host = HostBus.attach(bus)  # shared by every driver on this bus
        self.sdo = self.host.sdo(node_id, sdo_timeout, sdo_retries)
        self.health = EventSource[HealthEvent](self.host.scheduler)
        #: True once the device at ``node_id`` was confirmed to be this driver's model (or the
        #: application said not to check): until then a boot-up restores nothing
        self.confirmed = False
        self.nmt_state: NmtState | None = None  # as the device last reported it
        #: states NMT commands asked for that no heartbeat has reported yet, oldest first: a
        #: heartbeat sent before a command can still be on the wire after it went out, and
        #: answers an earlier command, never this one (issue 17: only what comes after counts)
        self._asked: list[NmtState] = []
        self.alive: bool | None = None
        self._heartbeat_timeout: float | None = None
        self._watch: Timer | None = None
        self._producer: Timer | None = None
        self.host_node_id = 0x7F
        #: held while the host heartbeat producer is replaced or stopped, and at close
        self._producer_lock = threading.Lock()
        self._closed = False
        self._unsubscribe: list[Callable[[], None]] = [
            self.host.subscribe(HEARTBEAT + node_id, self._on_heartbeat),
            self.host.subscribe(NMT, self._on_nmt_heard),
        ]

    # -- what a driver class builds on ------------------------------------------------------------

    def listen(self, can_id: int, handler: Handler) -> None:
        """Call ``handler(frame, now)`` on the bus thread for every frame of ``can_id`` until
        the driver closes."""
        self._unsubscribe.append(self.host.subscribe(can_id, handler))

    def on_close(self, release: Callable[[], None]) -> None:
        """Call ``release()`` when the driver closes (a link it opened, a subscription)."""
        self._unsubscribe.append(release)

    def pdo_frame(self, name: str, values: Mapping[str, int]) -> Frame:
        """The PDO ``name`` of this device with ``values``, from its layout in ``devices/``
        (signals not named: 0); built, not sent."""
        layout = self.description.pdo(name)
        return Frame(layout.cob_id(self.node_id), layout.encode(values))

    @property
    def health_id(self) -> int:
        """The id "lost" and :meth:`heard`'s "back" events name: the node id (a driver whose
        device speaks another protocol may name its address there)."""
        return self.node_id

    def heard(self, now: float) -> None:
        """The device was heard where it sends no CANopen heartbeat (a keypad in J1939 mode,
        its §18 heartbeat or any message): "back" if it was lost, and the watch of
        :meth:`monitor_heartbeat` starts again. On the bus thread."""
        if self.alive is False:
            self.health.emit(HealthEvent(self.health_id, BACK, now))
        self.alive = True
        self._rearm()

    # -- objects by name --------------------------------------------------------------------

    def entry(self, name: str) -> ObjectEntry:
        return self.description.table[name]

    def check(self, name: str, value: Value) -> ObjectEntry:
        """The entry, if ``value`` is valid for it; else ValueError naming the valid values."""
        entry = self.entry(name)
        if not entry.access.writable:
            raise ValueError(f"{entry.label} ({entry.index:04X}h/{entry.subindex:02X}) is "
                             "read-only")
        if not entry.accepts(value):
            raise ValueError(f"{entry.label} ({entry.index:04X}h/{entry.subindex:02X}) takes "
                             f"{entry.describe_valid()}, not {value!r}")
        return entry

    def read(self, name: str) -> Value:
        entry = self.entry(name)
        raw = self.sdo.upload(entry.index, entry.subindex)
        return entry.decode(raw)  # errata P3: a short reply of an integer reads as its value

    def write(self, name: str, value: Value) -> None:
        entry = self.check(name, value)
        self.sdo.download(entry.index, entry.subindex, entry.encode(value))

    def write_period(self, name: str, what: str, period: float, unit_s: float = 0.001) -> None:
        """Write ``period`` seconds to the entry ``name``, which counts ``unit_s`` units (0:
        off). A period it cannot hold is a ValueError naming the valid periods in seconds,
        before anything is sent: one that rounds to 0 (it would switch off what it sets) or
        that no integer holds included."""
        count = in_units(what, period, unit_s)
        entry = self.entry(name)
        if count is None or not entry.accepts(count) or (period > 0 and count == 0):
            valid = entry.valid or Ranges(((0, (1 << 8 * (entry.data_type.size or 4)) - 1),))
            raise ValueError(f"{what} must be {seconds_spans(valid.spans, unit_s)} s, not "
                             f"{period!r}")
        self.write(name, count)

    # -- NMT ----------------------------------------------------------------------------------

    def nmt(self, command: NmtCommand) -> None:
        self.host.run(lambda: self._nmt_commanded(command))  # known before any reply
        self.host.send(nmt_frame(command, self.node_id))
        self.nmt_command_sent(command)

    def _on_nmt_heard(self, frame: Frame, now: float) -> None:
        """Another master's NMT command to this node (or to all) explains what follows."""
        request = parse_nmt(frame, self.description.nmt_aliases)
        if request is not None and request.node_id in (0, self.node_id):
            self._nmt_commanded(request.command)
            self.nmt_command_sent(request.command)

    def _nmt_commanded(self, command: NmtCommand) -> None:
        asked = _ASKED.get(command)
        if asked is not None:
            self._asked = [*self._asked[-(_ASKED_KEPT - 1):], asked]
        self.nmt_command_seen(command)

    def _answered(self, state: NmtState) -> bool:
        """Whether a reported ``state`` is what a pending NMT command asked for; the commands
        up to that one are then carried out (an NMT slave acts on them in order). A report
        of the state already known answers only the oldest pending command: it may as well
        have been sent before the commands."""
        asked = self._asked
        if state not in asked or (state == self.nmt_state and asked[0] is not state):
            return False
        del asked[:asked.index(state) + 1]
        return True

    # -- hooks a driver class overrides: all but the last on the bus thread; applications do --
    # -- not call them --------------------------------------------------------------------------

    def nmt_command_seen(self, command: NmtCommand) -> None:
        """An NMT command was sent to the device (by this driver, or heard from another master
        on 000h): drivers update their picture."""

    def nmt_command_sent(self, command: NmtCommand) -> None:
        """An NMT command to the device is on the bus (this driver's, in its caller's thread
        once sent; another master's, as heard): what the device acts on only from now (a PDO
        after a start) may go."""

    def booted_up(self, now: float) -> None:
        """The confirmed device (re)booted: drivers restore what the application had set."""

    def watchdog_tripped(self, now: float) -> None:
        """The confirmed device's consumer heartbeat tripped: drivers update their picture."""

    def state_reported(self, state: NmtState, now: float) -> None:
        """The confirmed device reported a new NMT state (not a trip)."""

    def host_heartbeat_sent(self) -> None:
        """After each host heartbeat this driver sends: the device's consumer, if it watches
        this host, is armed from now on (KBX §28: monitoring starts at a heartbeat)."""

    def adopt_identity(self, found: Mapping[str, Value | None]) -> None:
        """:meth:`confirm` read ``found`` (1000h, 1018h/01, 100Bh by name), on its caller's
        thread; before they are compared with the description, a driver class that runs
        several models may take the description of the one they name."""

    # -- NMT commands ---------------------------------------------------------------------------

    def start(self) -> None:
        self.nmt(NmtCommand.START)

    def stop(self) -> None:
        self.nmt(NmtCommand.STOP)

    def enter_pre_operational(self) -> None:
        self.nmt(NmtCommand.ENTER_PRE_OPERATIONAL)

    def reset(self) -> None:
        self.nmt(NmtCommand.RESET_NODE)

    def reset_communication(self) -> None:
        self.nmt(NmtCommand.RESET_COMMUNICATION)

    # -- health -------------------------------------------------------------------------------

    def monitor_heartbeat(self, period: float, timeout: float | None = None) -> None:
        """Make the device send a heartbeat every ``period`` s (1017h) and raise "lost" when
        none comes for ``timeout`` (default 1.5 periods + 50 ms), "back" when it returns."""
        if timeout is not None:
            check_wait("heartbeat timeout", timeout)
        self.write_period("producer_heartbeat_time", "heartbeat period", period)
        self._watch_heartbeat(period, timeout)

    def _watch_heartbeat(self, period: float, timeout: float | None = None) -> None:
        self._heartbeat_timeout = timeout if timeout is not None else 1.5 * period + 0.05
        self.host.run(self._rearm)

    def on_health(self, callback: Callable[[HealthEvent], object]) -> Callable[[], None]:
        return self.health.subscribe(callback)

    def health_events(self, timeout: float | None = None) -> Iterator[HealthEvent]:
        return self.health.iterate(timeout)

    def _on_heartbeat(self, frame: Frame, now: float) -> None:
        if not frame.data:
            return
        code = frame.data[0]
        if self.alive is False:
            self.alive = True
            self.health.emit(HealthEvent(self.node_id, BACK, now))
        self.alive = True
        if code == NmtState.BOOT_UP:
            self.nmt_state, self._asked = NmtState.PRE_OPERATIONAL, []
            self.health.emit(HealthEvent(self.node_id, BOOT_UP, now, NmtState.BOOT_UP))
            if self.confirmed:  # never command a device before knowing what it is
                self.booted_up(now)
        elif code in NmtState._value2member_map_:
            asked = self._answered(NmtState(code))
            if code != self.nmt_state:
                self._on_reported(NmtState(code), now, asked)
        self._rearm()

    def _on_reported(self, state: NmtState, now: float, asked: bool) -> None:
        before, self.nmt_state = self.nmt_state, state
        self.health.emit(HealthEvent(self.node_id, STATE, now, state))
        # KBX §28 / rev 1.5 §26 note 2: a consumer heartbeat loss is the one way these
        # devices leave operational for pre-operational unasked
        if (before is NmtState.OPERATIONAL and state is NmtState.PRE_OPERATIONAL
                and not asked):
            self.health.emit(HealthEvent(self.node_id, WATCHDOG, now, state))
            if self.confirmed:
                self.watchdog_tripped(now)
        elif self.confirmed:
            self.state_reported(state, now)

    def _rearm(self) -> None:
        if self._watch is not None:
            self._watch.cancel()
        if self._heartbeat_timeout is not None:
            self._watch = self.host.call_later(self._heartbeat_timeout, self._lost)

    def _lost(self) -> None:
        self._watch = None
        if self.alive is not False:
            self.alive = False
            self.health.emit(HealthEvent(self.health_id, LOST, self.host.clock()))

    # -- which device answers ---------------------------------------------------------------------

    def confirm(self) -> None:
        """Read 1000h, 1018h/01 and 100Bh and compare them with this driver's description;
        :class:`WrongDeviceError` names what answered instead, :class:`NoDeviceError` says
        that nothing did, :class:`SharedNodeIdError` that more than one device answers.
        Drivers call it before their first command."""
        late = self.sdo.channel.late_replies
        try:
            found = self._identity_values()
        except SdoProtocolError:
            check_one_device(self.sdo)  # a second device's reply for the previous object?
            raise
        if self.sdo.channel.late_replies != late:  # a reply nobody awaited: a second device?
            check_one_device(self.sdo)
        self.adopt_identity(found)
        self._compare_identity(found)

    def _identity_values(self) -> dict[str, Value | None]:
        found: dict[str, Value | None] = {}
        for name in IDENTITY_ENTRIES:
            try:
                found[name] = self.read(name)
            except SdoTimeoutError as error:
                if found:  # it answered before: a real failure, not an absent device
                    raise
                raise NoDeviceError(f"no device answers at node {self.node_id:02X}h "
                                    f"({error})") from None
            except SdoAbortError:
                found[name] = None  # a device without the object: not ours
        return found

    def _compare_identity(self, found: dict[str, Value | None]) -> None:
        expected = {name: self.entry(name).default_for(self.node_id) for name in IDENTITY_ENTRIES}
        if found == expected:
            self.confirmed = True
            return
        device_type, model_id = found["device_type"], found["model_id"]
        answered = identify(device_type if isinstance(device_type, int) else None,
                            model_id if isinstance(model_id, str) else None)
        if answered is not None and all(
                found[name] == answered.table[name].default_for(self.node_id)
                for name in IDENTITY_ENTRIES):
            raise WrongDeviceError(f"node {self.node_id:02X}h is a {answered.title}, not a "
                                   f"{self.description.title}")

        def show(value: Value | None) -> str:
            return "none" if value is None else f"{value:08X}h" if isinstance(value, int) \
                else repr(value)

        raise WrongDeviceError(
            f"node {self.node_id:02X}h is not a {self.description.title}: device type "
            f"{show(device_type)}, vendor {show(found['vendor_id'])}, model {show(model_id)} "
            "answered")

    # -- identity -------------------------------------------------------------------------------

    def identity(self) -> Identity:
        def text(name: str) -> str:
            return str(self.read(name))

        return Identity(
            node_id=self.node_id,
            model=self.description.model,
            device_type=int(self.read("device_type")),
            vendor_id=int(self.read("vendor_id")),
            device_name=text("manufacturer_device_name"),
            model_id=text("model_id"),
            hardware_version=unreversed(text("manufacturer_hardware_version")),
            software_version=unreversed(text("manufacturer_software_version")),
            serial_number=(text("serial_number_string")
                           if "serial_number_string" in self.description.table else None),
        )

    # -- settings both devices have -------------------------------------------------------------

    def set_node_id(self, node_id: int, *, confirm: bool = False) -> None:
        """Store a new node id; it applies at the next reset, or at once on devices that say
        so (keypad generation 2, errata G1: the acknowledge then comes from the new id, and
        the device is to be driven there by a new driver). Needs ``confirm=True``."""
        check_node_id(node_id)
        if not confirm:
            raise ValueError("changing the node id moves the device on the bus at its next "
                             "reset: pass confirm=True")
        if node_id != self.node_id:
            self.check_free(node_id)
        if "node-id-at-once" in self.description.features and node_id != self.node_id:
            with self.sdo.channel.replies_also_from(node_id):
                self.write("node_id", node_id)
            return
        self.write("node_id", node_id)

    def check_free(self, node_id: int) -> None:
        """ValueError when a device already answers at ``node_id``: two devices on one node id
        would answer each other's SDO requests (one 1000h read, 0.2 s)."""
        try:
            self.host.sdo(node_id, 0.2, 0).upload(0x1000, 0)
        except SdoTimeoutError:
            return
        except SdoAbortError:
            pass  # it answered, if only with an abort
        raise ValueError(f"node id {node_id:02X}h is taken: a device answers there")

    def set_bitrate(self, bitrate: int, *, confirm: bool = False) -> None:
        """Store a bit rate (the device's own code, errata B1); it applies at the next reset."""
        code = self.description.bitrate_code(bitrate)
        if not confirm:
            raise ValueError("changing the bit rate takes the device off this bus at its next "
                             "reset: pass confirm=True")
        self.write("baud_rate", code)

    def set_boot_up(self, enabled: bool) -> None:
        self.write("boot_up_service", int(enabled))

    def set_active_on_startup(self, enabled: bool) -> None:
        self.write("active_on_startup", int(enabled))

    def set_heartbeat(self, period: float) -> None:
        """Producer heartbeat every ``period`` seconds; 0 switches it off."""
        self.write_period("producer_heartbeat_time", "heartbeat period", period)

    # -- the device watching the controller (KBX §28, PKP rev 1.5 §26) ----------------------------

    def set_consumer_heartbeat(self, node_id: int, period: float) -> None:
        """Watch ``node_id``'s heartbeat; missing it for ``period`` s switches the device off
        (Keybox: outputs; keypad generation 2: LEDs). ``period`` 0 stops watching."""
        check_node_id(node_id)
        ms = in_units("consumer heartbeat period", period, 0.001)
        if "consumer_heartbeat_time" not in self.description.table:
            raise ValueError(f"this {self.description.kind} (manual {self.description.generation}"
                             ") has no consumer heartbeat (1016h)")
        rule = self.description.consumer_heartbeat
        assert rule is not None, "a description with 1016h says what it accepts"
        if ms is None or ms not in rule.times_ms or (period > 0 and ms == 0):
            raise ValueError("consumer heartbeat period must be "
                             f"{seconds_spans(rule.times_ms.spans, 0.001)} s, not {period}")
        self.write("consumer_heartbeat_time", rule.compose(ms, node_id))

    def restore_factory_defaults(self, *, confirm: bool = False) -> None:
        """Every stored setting back to factory values at the next reset (1011h "load"; the
        firmware's 43h acknowledge is accepted, errata K3/G5)."""
        if "restore_all_parameters" not in self.description.table:
            raise ValueError(f"this {self.description.kind} (manual "
                             f"{self.description.generation}) cannot restore defaults (1011h)")
        if not confirm:
            raise ValueError("this erases every stored setting at the next reset: pass "
                             "confirm=True")
        self.write("restore_all_parameters", RESTORE_SIGNATURE)

    def watch_host(self, period: float) -> None:
        """Send a host heartbeat every ``period`` s and have the device switch off when it
        misses two (KBX §28 note 1: consumer time about twice the producer's). The device's
        own heartbeat is turned on (every ``period`` s) if it was off, so that a trip is seen:
        a "watchdog" health event."""
        check_watchdog(period)
        self.set_consumer_heartbeat(self.host_node_id, 2 * period)
        if self._heartbeat_timeout is None:
            own_ms = int(self.read("producer_heartbeat_time"))
            if own_ms:
                self._watch_heartbeat(own_ms / 1000)
            else:
                self.monitor_heartbeat(period)
        frame = Frame(HEARTBEAT + self.host_node_id, bytes((NmtState.OPERATIONAL,)))
        with self._producer_lock:  # one producer, whichever threads call this at once
            if self._producer is not None:
                self._producer.cancel()
            self._producer = self.host.call_every(period,
                                                  lambda: self._send_host_heartbeat(frame))

    def _send_host_heartbeat(self, frame: Frame) -> None:
        self.host.send(frame)
        self.host_heartbeat_sent()

    def stop_host_heartbeat(self) -> None:
        """Stop the host heartbeat (as a crashed application would): the device reacts."""
        with self._producer_lock:
            if self._producer is not None:
                self._producer.cancel()
                self._producer = None

    # -- lifecycle --------------------------------------------------------------------------------

    def close(self) -> None:
        """Let go of the bus; a second close (from any thread) does nothing."""
        with self._producer_lock:
            if self._closed:
                return
            self._closed = True
        self.stop_host_heartbeat()
        for unsubscribe in self._unsubscribe:
            unsubscribe()
        if self._watch is not None:
            self._watch.cancel()
        self.host.release()  # first: whoever the end of an iterator wakes finds the bus let go
        for value in list(vars(self).values()):
            if isinstance(value, EventSource):
                value.close()  # iterators over this driver's events end

    def __enter__(self) -> Any:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()
