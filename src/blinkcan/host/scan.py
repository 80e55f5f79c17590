"""Find Blink devices on a bus: boot-up and heartbeat frames heard, then an SDO read of 1000h
on every node id at once, and identity (1018h vendor 3E2h, 100Bh model, versions) of those that
answer. Models are recognised from the registry's identity values (100Bh, else 1000h).

Every reply to the 1000h read within the timeout counts: more than one device answering at a
node id (a wiring mistake, two emulators) is reported as such (``Found.answers``), and their
identity is not read (each request would get replies from both, taken for one another).
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import can

from blinkcan.devices.registry import identify
from blinkcan.host.bus import HostBus
from blinkcan.host.device import unreversed
from blinkcan.host.identity_errors import several_answer
from blinkcan.host.sdo import SdoClient
from blinkcan.protocol.cob import HEARTBEAT, NODE_ID_MAX, NODE_ID_MIN
from blinkcan.protocol.frame import Frame
from blinkcan.protocol.sdo import SCS_INITIATE_UPLOAD, parse_sdo
from blinkcan.protocol.sdo_client import SdoError


@dataclass(frozen=True)
class Found:
    """A device that answered. ``kind`` is "keypad", "keybox" or None for a foreign device;
    ``model`` the registered model ("pkp-2600-si") or None."""

    node_id: int
    kind: str | None
    device_type: int
    vendor_id: int | None = None
    model_id: str | None = None
    hardware_version: str | None = None
    software_version: str | None = None
    heard: bool = False  # a boot-up or heartbeat was seen during the scan
    model: str | None = None
    #: devices that answered the 1000h read: more than one share the node id (a mistake)
    answers: int = 1

    @property
    def shared(self) -> bool:
        """More than one device answers at this node id."""
        return self.answers > 1

    def describe_shared(self) -> str:
        """"two devices answer at node 15h ..." (for a shared node id)."""
        return several_answer(self.answers, self.node_id)


def _text(channel: SdoClient, index: int) -> str | None:
    try:
        return channel.upload(index, 0).decode("ascii", "replace")
    except SdoError:
        return None


def _expedited_value(reply: bytes) -> int | None:
    """The value of an expedited upload response (None for an abort or a segmented one)."""
    parsed = parse_sdo(reply)  # answers() gives eight-byte replies only
    if parsed.specifier != SCS_INITIATE_UPLOAD or not parsed.expedited:
        return None
    return int.from_bytes(parsed.expedited_data, "little")


#: times an identity read (1018h, 100Bh, 1009h, 100Ah) is asked again once 1000h answered
IDENTITY_RETRIES = 2


def scan(bus: HostBus | can.BusABC, listen: float = 0.3, timeout: float = 0.2,
         node_ids: range = range(NODE_ID_MIN, NODE_ID_MAX + 1)) -> list[Found]:
    """Blink (and other CANopen) devices on ``bus``, by node id."""
    host = HostBus.attach(bus)
    heard: set[int] = set()

    def hear(frame: Frame, now: float) -> None:
        heard.add(frame.can_id - HEARTBEAT)

    removers = [host.subscribe(HEARTBEAT + node, hear) for node in node_ids]
    try:
        host.sleep(listen)

        def probe(node: int) -> Found | None:
            channel = host.sdo(node, timeout=timeout, retries=0)
            replies = channel.channel.answers(0x1000, 0, timeout)
            if not replies or parse_sdo(replies[0]).is_abort:
                return None  # nothing, or a device without 1000h: not CANopen
            if len(replies) > 1:  # their identity reads would be taken for one another
                types = {_expedited_value(reply) for reply in replies}
                device_type = min(t if t is not None else 0 for t in types)
                same = identify(device_type) if len(types) == 1 else None
                return Found(node, same.kind if same else None, device_type,
                             heard=node in heard, answers=len(replies))
            return identity(node, _expedited_value(replies[0]), timeout)

        def identity(node: int, device_type: int | None, window: float) -> Found | None:
            # the device is there: a reply lost now (a busy bus, a loaded host) is asked again,
            # so that it never makes a known device "other CANopen" or a blank column
            channel = host.sdo(node, timeout=window, retries=IDENTITY_RETRIES)
            try:
                if device_type is None:
                    device_type = int.from_bytes(channel.upload(0x1000, 0), "little")
            except SdoError:
                return None
            try:
                vendor = int.from_bytes(channel.upload(0x1018, 1), "little")
            except SdoError:
                vendor = None
            model_id = _text(channel, 0x100B)
            known = identify(device_type, model_id) or identify(device_type)
            if known is not None and known.table["vendor_id"].default != vendor:
                known = None
            hardware, software = _text(channel, 0x1009), _text(channel, 0x100A)
            return Found(node, known.kind if known else None, device_type, vendor, model_id,
                         unreversed(hardware) if hardware else None,
                         unreversed(software) if software else None, node in heard,
                         known.model if known else None)

        if host.simulated:  # one thread drives the simulation: probe in turn
            found = [f for f in map(probe, node_ids) if f is not None]
        else:
            with ThreadPoolExecutor(max_workers=32) as pool:
                found = [f for f in pool.map(probe, node_ids) if f is not None]
        # A node that sent a heartbeat, or whose 1000h reply came after its window (a loaded
        # host reads late), is there: read its identity as a driver does (retries, a window
        # twice as long), so that the host's own lateness never drops a present device. A
        # silent node is not asked twice.
        answered = {f.node_id for f in found}
        for node in node_ids:
            if node not in answered and (node in heard or host.sdo(node).channel.late_replies):
                again = identity(node, None, 2 * timeout)
                if again is not None:
                    found.append(again)
    finally:
        for remove in removers:
            remove()
        host.release()
    return sorted(found, key=lambda f: f.node_id)
