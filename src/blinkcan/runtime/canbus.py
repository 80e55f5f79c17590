"""Frame <-> python-can Message, and opening buses the way python-can's own tools do."""

from __future__ import annotations

import collections
import threading
from typing import Any

import can

from blinkcan.protocol.frame import Frame


def to_message(frame: Frame, timestamp: float = 0.0) -> can.Message:
    return can.Message(
        arbitration_id=frame.can_id,
        data=frame.data,
        is_extended_id=frame.extended,
        timestamp=timestamp,
        check=False,
    )


def to_frame(message: can.Message) -> Frame | None:
    """A data frame as :class:`Frame`; None for remote, error and CAN FD frames over 8 bytes."""
    if message.is_error_frame or message.is_remote_frame or message.dlc > 8:
        return None
    data = message.data
    if len(data) > 8:
        return None
    # python-can checked the identifier; Frame.trusted skips checking it again
    return Frame.trusted(message.arbitration_id, bytes(data), message.is_extended_id)


def open_bus(interface: str | None = None, channel: str | None = None,
             bitrate: int | None = None, **kwargs: Any) -> can.BusABC:
    """A python-can bus. With no interface named, python-can's configuration (file or
    environment) decides; with none configured either, a ``virtual`` bus on channel
    ``blinkcan``."""
    config: dict[str, Any] = dict(kwargs)
    if channel is not None:
        config["channel"] = channel
    if bitrate is not None:
        config["bitrate"] = bitrate
    if interface is None:
        try:
            can.util.load_config(config=dict(config))
        except can.CanInterfaceNotImplementedError:
            interface = "virtual"
            config.setdefault("channel", "blinkcan")
    if interface is not None:
        config["interface"] = interface
    if config.get("interface") == "virtual":
        config.setdefault("channel", "blinkcan")
    return can.Bus(**config)


def echoes_own_frames(bus: can.BusABC) -> bool:
    """Whether ``bus`` hands its own sent frames back as received ones: python-can's
    ``udp_multicast`` does (multicast loopback reaches every socket of the group on this
    machine, the sender's included), and python-can cannot switch that off."""
    return type(bus).__name__ == "UdpMulticastBus"


class OwnFrames:
    """Recognises a bus's own frames when the bus echoes them (see :func:`echoes_own_frames`).

    Frames sent are remembered by content for ``window`` seconds; a received frame equal to one
    of them is the echo and is consumed. An equal frame from another node within that window is
    indistinguishable from the echo; it is consumed instead and the echo passes: the receiver
    sees the same content either way. Thread-safe: senders and the reader may differ.
    """

    def __init__(self, bus: can.BusABC, window: float = 2.0) -> None:
        self.active = echoes_own_frames(bus)
        self.window = window
        self._pending: collections.Counter[tuple[int, bytes, bool]] = collections.Counter()
        self._order: collections.deque[tuple[float, tuple[int, bytes, bool]]] = (
            collections.deque())
        self._lock = threading.Lock()

    def sent(self, frame: Frame, now: float) -> None:
        if not self.active:
            return
        key = (frame.can_id, frame.data, frame.extended)
        with self._lock:
            self._expire(now)
            self._pending[key] += 1
            self._order.append((now, key))

    def is_echo(self, frame: Frame, now: float) -> bool:
        if not self.active:
            return False
        key = (frame.can_id, frame.data, frame.extended)
        with self._lock:
            self._expire(now)
            count = self._pending.get(key, 0)
            if not count:
                return False
            if count == 1:
                del self._pending[key]
            else:
                self._pending[key] = count - 1
            for i, (_, pending) in enumerate(self._order):
                if pending == key:
                    del self._order[i]
                    break
            return True

    def _expire(self, now: float) -> None:
        order, pending = self._order, self._pending
        while order and now - order[0][0] > self.window:
            _, key = order.popleft()
            count = pending.get(key, 0)
            if count <= 1:
                pending.pop(key, None)
            else:
                pending[key] = count - 1


class BusReader:
    """Reads ``bus`` for one listener: joins the notifier that already reads it (``notifier``,
    or the one python-can's ``Notifier.find_instances`` finds: a python-canopen ``Network``'s,
    the application's, another blinkcan part's), else starts one. Never two notifiers on one
    bus (python-can refuses them)."""

    def __init__(self, bus: can.BusABC, listener: can.Listener,
                 notifier: can.Notifier | None = None) -> None:
        self.listener = listener
        self._own: can.Notifier | None = None
        for _attempt in range(3):
            if notifier is None:
                found = can.Notifier.find_instances(bus)
                notifier = found[0] if found else None
            if notifier is not None:
                break
            try:
                self._own = can.Notifier(bus, [listener], timeout=0.1)
                break
            except ValueError:  # another thread put a notifier on the bus meanwhile: join it
                continue
        self._joined = notifier
        if notifier is not None:
            notifier.add_listener(listener)
        elif self._own is None:
            raise RuntimeError(f"could not read {bus.channel_info}: its notifier kept changing")

    def stop(self) -> None:
        """Stop reading: our own notifier stops (from any thread, its own included), a joined
        one keeps reading for the others."""
        own, self._own = self._own, None
        if own is not None:
            if threading.current_thread().name.startswith("can.notifier"):
                threading.Thread(target=own.stop, daemon=True).start()
            else:
                own.stop()
        joined, self._joined = self._joined, None
        if joined is not None and self.listener in joined.listeners:
            joined.remove_listener(self.listener)
