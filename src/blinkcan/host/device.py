"""What every host driver does the same way, read from the device's object table.

Objects are named as in ``devices/`` (``driver.read("producer_heartbeat_time")``); a value is
checked against the table before anything is sent, so a bad argument raises ``ValueError``
naming the valid range and the bus sees nothing.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any

import can

from blinkcan.devices.common import RESTORE_SIGNATURE
from blinkcan.devices.model import DeviceDescription
from blinkcan.devices.objects import ObjectEntry, Value
from blinkcan.host.bus import HostBus, Timer
from blinkcan.host.events import EventSource
from blinkcan.protocol.cob import HEARTBEAT, check_node_id, check_range
from blinkcan.protocol.frame import Frame
from blinkcan.protocol.nmt import NmtCommand, NmtState, nmt_frame


def unreversed(version: str) -> str:
    """errata P5/P6: some firmware sends "10_V" for "V_01" and "2.2V" for "V2.2"; a value that
    ends in V and reads right reversed is reversed."""
    if version.endswith("V") and not version.startswith("V"):
        return version[::-1]
    return version


@dataclass(frozen=True)
class Identity:
    node_id: int
    model: str
    device_type: int
    vendor_id: int
    device_name: str
    model_id: str
    hardware_version: str
    software_version: str
    serial_number: str | None = None  # the keypad's 2200h; the Keybox documents none


@dataclass(frozen=True)
class HealthEvent:
    """``kind``: "boot-up", "lost" (heartbeat missed) or "back" (heard again)."""

    node_id: int
    kind: str
    time: float
    state: NmtState | None = None


class Device:
    """A Blink CANopen device seen from the controller."""

    def __init__(self, bus: HostBus | can.BusABC, node_id: int, description: DeviceDescription,
                 *, sdo_timeout: float = 0.5, sdo_retries: int = 1) -> None:
        self.node_id = check_node_id(node_id)
        self.description = description
        self.host = HostBus.attach(bus)  # shared by every driver on this bus
        self.sdo = self.host.sdo(node_id, sdo_timeout, sdo_retries)
        self.health = EventSource[HealthEvent](self.host.scheduler)
        self.nmt_state: NmtState | None = None
        self.alive: bool | None = None
        self._heartbeat_timeout: float | None = None
        self._watch: Timer | None = None
        self._producer: Timer | None = None
        self.host_node_id = 0x7F
        self._unsubscribe: list[Callable[[], None]] = [
            self.host.subscribe(HEARTBEAT + node_id, self._on_heartbeat),
        ]

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

    # -- NMT ----------------------------------------------------------------------------------

    def nmt(self, command: NmtCommand) -> None:
        self.host.send(nmt_frame(command, self.node_id))

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
        self.write("producer_heartbeat_time", round(period * 1000))
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
            self.health.emit(HealthEvent(self.node_id, "back", now))
        self.alive = True
        if code == NmtState.BOOT_UP:
            self.nmt_state = NmtState.PRE_OPERATIONAL
            self.health.emit(HealthEvent(self.node_id, "boot-up", now, NmtState.BOOT_UP))
            self._on_boot_up(now)
        elif code in NmtState._value2member_map_:
            self.nmt_state = NmtState(code)
        self._rearm()

    def _rearm(self) -> None:
        if self._watch is not None:
            self._watch.cancel()
        if self._heartbeat_timeout is not None:
            self._watch = self.host.call_later(self._heartbeat_timeout, self._lost)

    def _lost(self) -> None:
        self._watch = None
        if self.alive is not False:
            self.alive = False
            self.health.emit(HealthEvent(self.node_id, "lost", self.host.clock()))

    def _on_boot_up(self, now: float) -> None:
        """The device (re)booted: drivers restore what the application had set."""

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
        """Store a new node id; it applies at the next reset. Needs ``confirm=True``."""
        check_node_id(node_id)
        if not confirm:
            raise ValueError("changing the node id moves the device on the bus at its next "
                             "reset: pass confirm=True")
        self.write("node_id", node_id)

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
        self.write("producer_heartbeat_time", round(period * 1000))

    # -- the device watching the controller (KBX §28, PKP rev 1.5 §26) ----------------------------

    def set_consumer_heartbeat(self, node_id: int, period: float) -> None:
        """Watch ``node_id``'s heartbeat; missing it for ``period`` s switches the device off
        (Keybox: outputs; keypad generation 2: LEDs). ``period`` 0 stops watching."""
        check_node_id(node_id)
        if "consumer_heartbeat_time" not in self.description.table:
            raise ValueError(f"this {self.description.kind} (manual {self.description.generation}"
                             ") has no consumer heartbeat (1016h)")
        ms = round(period * 1000)
        if ms and not 10 <= ms <= 0xFEFF:
            raise ValueError(f"consumer heartbeat period must be 0 or 0.01..65.279 s, not {period}")
        self.write("consumer_heartbeat_time", ms | node_id << 16)

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
        misses two (KBX §28 note 1: consumer time about twice the producer's)."""
        check_range("watchdog period in ms", round(period * 1000), 10, 0xFEFF // 2)
        self.set_consumer_heartbeat(self.host_node_id, 2 * period)
        if self._producer is not None:
            self._producer.cancel()
        frame = Frame(HEARTBEAT + self.host_node_id, bytes((NmtState.OPERATIONAL,)))
        self._producer = self.host.call_every(period, lambda: self.host.send(frame))

    def stop_host_heartbeat(self) -> None:
        """Stop the host heartbeat (as a crashed application would): the device reacts."""
        if self._producer is not None:
            self._producer.cancel()
            self._producer = None

    # -- lifecycle --------------------------------------------------------------------------------

    def close(self) -> None:
        self.stop_host_heartbeat()
        for unsubscribe in self._unsubscribe:
            unsubscribe()
        if self._watch is not None:
            self._watch.cancel()
        for value in list(vars(self).values()):
            if isinstance(value, EventSource):
                value.close()  # iterators over this driver's events end
        self.host.release()

    def __enter__(self) -> Any:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()
