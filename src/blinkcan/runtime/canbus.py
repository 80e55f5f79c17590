"""Frame <-> python-can Message, and opening buses the way python-can's own tools do."""

from __future__ import annotations

import collections
import logging
import math
import operator
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import can

from blinkcan.protocol.frame import Frame

log = logging.getLogger(__name__)
_MAX_BACKOFF = 1.0
_new_tuple = tuple.__new__


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
    # python-can checked the identifier: no checks again (Frame.trusted, inlined: every frame)
    return _new_tuple(Frame, (message.arbitration_id, bytes(data), message.is_extended_id))


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
    of them is the echo and is consumed (the oldest of equal ones first). An equal frame from
    another node within that window is indistinguishable from the echo; it is consumed instead
    and the echo passes: the receiver sees the same content either way. Thread-safe: senders and
    the reader may differ. Every frame sent and received passes here: the reader takes no lock
    (a dict lookup, and a deque's atomic popleft for an echo); senders take one, and forget the
    frames whose echoes never came once a window.
    """

    def __init__(self, bus: can.BusABC, window: float = 2.0) -> None:
        self.active = echoes_own_frames(bus)
        self.window = window
        #: frame -> the times it was sent, oldest first, echo not yet seen (the reader only
        #: pops from a deque; only senders, under the lock, add and remove keys). A reader may
        #: look a received frame up here first: :meth:`is_echo` can be true only where it
        #: finds a non-empty deque
        self.pending: dict[Frame, collections.deque[float]] = {}
        #: when :meth:`sweep` is due next (a sender sweeps, holding the lock)
        self.sweep_at = -math.inf
        #: held by a sender while it adds to or removes from ``pending``
        self.lock = threading.Lock()

    def sent(self, frame: Frame, now: float) -> None:
        if not self.active:
            return
        with self.lock:
            times = self.pending.get(frame)
            if times is None:
                self.pending[frame] = collections.deque((now,))
            else:
                times.append(now)
            if now >= self.sweep_at:
                self.sweep(now)

    def is_echo(self, frame: Frame, now: float) -> bool:
        if not self.active:
            return False
        times = self.pending.get(frame)
        if not times:  # never sent (it is there before its echo can come back)
            return False
        window = self.window
        while True:
            try:
                sent_at = times.popleft()
            except IndexError:
                return False
            if now - sent_at <= window:
                return True
            # older than the window: that echo never came; the next one may be this

    def sweep(self, now: float) -> None:
        """Forget the frames whose every echo is in or older than the window's past (a
        sender calls it, holding the lock)."""
        self.sweep_at = now + self.window
        window = self.window
        pending = self.pending
        for frame, times in list(pending.items()):
            try:
                if now - times[-1] > window:
                    del pending[frame]
            except IndexError:  # all echoes came
                del pending[frame]


@dataclass
class ReadStats:
    """What a :class:`BusReader` met on its bus (updated on the reader thread)."""

    #: frames the bus received but could not decode (dropped; the first one is logged)
    undecodable: int = 0
    #: read errors in a row with no frame between: the bus is failing while this is > 0
    failures: int = 0
    #: the last read error of a failing bus (None while it reads)
    error: Exception | None = None
    #: the bus was shut down: nothing is read from it any more
    closed: bool = False


def is_undecodable(error: Exception) -> bool:
    """Whether ``error`` says that one received frame could not be decoded while the bus
    itself works: python-can raises ``CanOperationError`` *from* the decoder's exception
    (``udp_multicast``: "could not unpack received message", from msgpack, on any datagram
    that is not a python-can frame), whereas a failing bus raises from an ``OSError`` or with
    no cause at all."""
    cause = error.__cause__
    return (isinstance(error, can.CanError) and cause is not None
            and not isinstance(cause, OSError))


class _Reading(can.Listener):
    """The listener a :class:`BusReader` puts on the notifier: frames go straight to the
    reader's listener (no extra call while the bus works), errors to the reader."""

    #: the notifier calls a listener per frame: this hands it the present
    #: ``on_message_received`` (C-level getter, so no Python frame between the notifier and
    #: the reader's listener, as ``can.Listener.__call__`` would add on every frame)
    __call__ = property(operator.attrgetter("on_message_received"))

    def __init__(self, reader: BusReader) -> None:
        self.reader = reader
        self.listener = reader.listener
        self.on_message_received = reader.listener.on_message_received  # type: ignore[method-assign]

    def failing(self) -> None:
        """The next frame ends the failure first."""
        self.on_message_received = self._first_after_failure  # type: ignore[method-assign]

    def on_message_received(self, msg: can.Message) -> None:
        """Replaced per instance by :meth:`working` and :meth:`failing`."""
        self.listener.on_message_received(msg)

    def working(self) -> None:
        self.on_message_received = self.listener.on_message_received  # type: ignore[method-assign]

    def _first_after_failure(self, msg: can.Message) -> None:
        self.reader._recovered()
        self.listener.on_message_received(msg)

    def on_error(self, exc: Exception) -> None:
        self.reader._on_error(exc)


class BusReader:
    """Reads ``bus`` for one listener: joins the notifier that already reads it (``notifier``,
    or the one python-can's ``Notifier.find_instances`` finds: a python-canopen ``Network``'s,
    the application's, another blinkcan part's), else starts one. Never two notifiers on one
    bus (python-can refuses them).

    One behaviour on bus errors for every reader in blinkcan (drivers and emulator alike),
    counted in :attr:`stats`:

    - a frame the bus cannot decode is dropped and counted; the first one is logged (the total
      again when the reader stops). It never slows the reader: the bus works;
    - a failing bus (read errors in a row, no frame between) is reported once and read with a
      back-off (up to 1 s) instead of a busy loop; the next frame ends it (logged);
    - a shut-down bus is reported once and stops the reader; ``on_closed()`` is called.
    """

    def __init__(self, bus: can.BusABC, listener: can.Listener,
                 notifier: can.Notifier | None = None, *, stats: ReadStats | None = None,
                 on_closed: Callable[[], object] | None = None) -> None:
        self.bus = bus
        #: the bus in log lines (python-can names some buses' channel "unknown")
        self.name = (bus.channel_info if bus.channel_info != "unknown"
                     else type(bus).__name__)
        self.listener = listener
        self.stats = stats if stats is not None else ReadStats()
        self._on_closed = on_closed
        self._reading = _Reading(self)
        self._own: can.Notifier | None = None
        for _attempt in range(3):
            if notifier is None:
                found = can.Notifier.find_instances(bus)
                notifier = found[0] if found else None
            if notifier is not None:
                break
            try:
                self._own = can.Notifier(bus, [self._reading], timeout=0.1)
                break
            except ValueError:  # another thread put a notifier on the bus meanwhile: join it
                continue
        self._joined = notifier
        if notifier is not None:
            notifier.add_listener(self._reading)
        elif self._own is None:
            raise RuntimeError(f"could not read {bus.channel_info}: its notifier kept changing")

    @staticmethod
    def listeners_of(bus: can.BusABC) -> list[can.Listener]:
        """The listeners blinkcan's readers feed on ``bus``."""
        return [listener.listener for notifier in can.Notifier.find_instances(bus)
                for listener in notifier.listeners if isinstance(listener, _Reading)]

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
        if joined is not None and self._reading in joined.listeners:
            joined.remove_listener(self._reading)
        if (own is not None or joined is not None) and self.stats.undecodable > 1:
            log.warning("bus %s: %d frames that could not be decoded were dropped",
                        self.name, self.stats.undecodable)

    # -- on the reader thread -----------------------------------------------------------------

    def _on_error(self, error: Exception) -> None:
        stats = self.stats
        if getattr(self.bus, "_is_shutdown", False):
            if not stats.closed:
                stats.closed, stats.error = True, error
                log.error("bus %s was shut down; blinkcan stops reading it",
                          self.name)
                if self._on_closed is not None:
                    self._on_closed()
                threading.Thread(target=self.stop, daemon=True).start()
            time.sleep(0.1)  # until the notifier has stopped: no busy loop
            return
        if is_undecodable(error):
            stats.undecodable += 1
            if stats.undecodable == 1:
                log.warning("bus %s received a frame it cannot decode (%s: %s); dropped, as "
                            "every other one will be (counted, not logged)",
                            self.name, error, error.__cause__)
            if stats.failures:
                self._recovered()  # the bus delivered something: it reads
            return
        stats.failures += 1
        stats.error = error
        if stats.failures == 1:
            self._reading.failing()
            log.error("reading bus %s failed: %s (retrying with back-off, reported once)",
                      self.name, error)
        time.sleep(min(_MAX_BACKOFF, 0.01 * 2 ** min(stats.failures, 8)))

    def _recovered(self) -> None:
        self._reading.working()
        log.warning("bus %s reads again after %d errors", self.name,
                    self.stats.failures)
        self.stats.failures = 0
        self.stats.error = None
