"""The python-can port: any python-can bus as a :class:`~blinkcan.runtime.port.Port`.

Frames are read the way every blinkcan reader reads (``runtime.canbus.BusReader``: joins the
notifier already on the bus, counts undecodable frames, backs off from a failing bus, stops at
a shut-down one) and handed to the handlers on the reader thread. Frames this port sent never
come back as received ones, also on python-can's ``udp_multicast``, which echoes them
(``runtime.canbus.OwnFrames``). The port's scheduler runs in real time on a thread of its own.
"""

from __future__ import annotations

import collections
import time
from collections.abc import Callable

import can

from blinkcan.protocol.frame import Frame
from blinkcan.runtime.canbus import BusReader, OwnFrames, ReadStats, to_message
from blinkcan.runtime.scheduler import RealTimeScheduler

FrameHandler = Callable[[Frame, float], None]
_new_tuple = tuple.__new__
_new_object = object.__new__
#: python-can's Message fields, as :func:`_message` sets them all
_MESSAGE_FIELDS = frozenset({
    "arbitration_id", "bitrate_switch", "channel", "data", "dlc", "error_state_indicator",
    "is_error_frame", "is_extended_id", "is_fd", "is_remote_frame", "is_rx", "timestamp"})
#: python-can buses whose ``send`` is done with the Message when it returns (udp_multicast
#: packs it, virtual deep-copies it) and takes the send time from its own clock (udp_multicast:
#: the receiver's socket stamps it; virtual: unless ``preserve_timestamps``)
_SEND_COPIES = frozenset({"UdpMulticastBus", "VirtualBus"})
#: distinct frames whose Message a reusing port keeps (a device answers the same few requests
#: with the same few replies; a master polls the same few requests). Cleared when full.
_MESSAGES_KEPT = 256


def _message(frame: Frame, timestamp: float) -> can.Message:
    """:func:`~blinkcan.runtime.canbus.to_message`, without ``Message.__init__``'s keyword
    handling (half the cost of a send: every frame sent comes this way): every field set as
    the constructor sets it for a data frame."""
    message: can.Message = _new_object(can.Message)
    message.timestamp = timestamp
    message.arbitration_id = frame.can_id
    message.is_extended_id = frame.extended
    message.is_remote_frame = False
    message.is_error_frame = False
    message.channel = None
    message.is_fd = False
    message.is_rx = True
    message.bitrate_switch = False
    message.error_state_indicator = False
    data = message.data = bytearray(frame.data)
    message.dlc = len(data)
    return message


def _message_maker() -> Callable[[Frame, float], can.Message]:
    """:func:`_message` where python-can's Message has exactly the fields it sets, else the
    constructor (a python-can with other fields)."""
    fields = set(getattr(can.Message, "__slots__", ())) - {"__weakref__"}
    return _message if fields == _MESSAGE_FIELDS else to_message


def reuses_messages(bus: can.BusABC) -> bool:
    """Whether a Message may be sent again on ``bus``: python-can's own udp_multicast and
    virtual buses are done with it when ``send`` returns and stamp the time themselves (a
    virtual bus that preserves timestamps excepted). Any other bus gets a new Message per
    frame (it may queue it, or keep it as sent)."""
    return (type(bus).__name__ in _SEND_COPIES and type(bus).__module__.startswith("can.")
            and not getattr(bus, "preserve_timestamps", False))


class _PortListener(can.Listener):
    """What the port's reader feeds: a message becomes a frame, an echo of the port's own is
    dropped, every handler gets the rest."""

    def __init__(self, port: CanBusPort) -> None:
        self.port = port
        self.clock = port.clock
        #: the frames sent whose echo may still come, on a bus that echoes its own frames
        #: (udp_multicast), else None; and the echo check, asked where a frame is among them.
        #: Bound once: every frame received looks
        self.pending = port.own.pending if port.own.active else None
        self.window = port.own.window
        self.is_echo = port.own.is_echo

    def on_message_received(self, msg: can.Message) -> None:
        # runtime.canbus.to_frame, inlined (every frame received comes this way): data frames
        # of up to eight bytes; python-can checked the identifier (Frame.trusted)
        data = msg.data
        if msg.is_error_frame or msg.is_remote_frame or msg.dlc > 8 or len(data) > 8:
            return
        frame = _new_tuple(Frame, (msg.arbitration_id, bytes(data), msg.is_extended_id))
        now = self.clock()
        pending = self.pending
        if pending is not None:
            times = pending.get(frame)
            if times:  # sent here, its echo not yet seen: OwnFrames.is_echo, its usual case
                # inlined (the oldest sending is within the window), the rest asked of it
                try:
                    if now - times.popleft() <= self.window or self.is_echo(frame, now):
                        return
                except IndexError:  # emptied meanwhile: this one is no echo
                    pass
        try:
            for handler in self.port.handlers:
                handler(frame, now)
        except Exception as error:  # a handler's defect is not a failing bus
            self.port.scheduler.failed(error, "a frame handler")


class CanBusPort:
    """A python-can ``bus``, read through ``notifier`` (or the one already on the bus, or a
    notifier of its own), with a real-time scheduler named ``name`` on ``clock``."""

    def __init__(self, bus: can.BusABC, *, notifier: can.Notifier | None = None,
                 clock: Callable[[], float] = time.monotonic, name: str = "blinkcan") -> None:
        self.bus = bus
        self.clock = clock
        self.scheduler = RealTimeScheduler(name, clock)
        self.reading = ReadStats()
        self.own = OwnFrames(bus)
        #: the record of a frame sent, where the bus echoes (else None): bound once
        self._sent = self.own.sent if self.own.active else None
        #: the frames sent whose echo may still come, where the bus echoes (else None)
        self._pending = self.own.pending if self.own.active else None
        #: the handlers, a tuple: the reader reads it per frame, listen and detach replace it
        self.handlers: tuple[FrameHandler, ...] = ()
        self._notifier = notifier
        self._on_closed: list[Callable[[], object]] = []
        self._reader: BusReader | None = None
        self._listener = _PortListener(self)
        self._message = _message_maker()
        #: frame -> the Message sent for it, where the bus is done with a Message when its
        #: send returns (:func:`reuses_messages`): one Message per distinct frame, not per send
        self._messages: dict[Frame, can.Message] = {}
        if reuses_messages(bus):
            self.send = self._send_kept  # type: ignore[method-assign]

    def send(self, frame: Frame) -> None:
        now = self.clock()
        sent = self._sent
        if sent is not None:
            sent(frame, now)
        self.bus.send(self._message(frame, now))

    def _send_kept(self, frame: Frame) -> None:
        """:meth:`send`, reusing the Message of an equal frame sent before (every SDO request
        and reply comes this way: building a Message costs more than the rest of a send)."""
        now = self.clock()
        pending = self._pending
        if pending is not None:  # OwnFrames.sent, inlined (every frame sent on udp_multicast)
            own = self.own
            with own.lock:
                times = pending.get(frame)
                if times is None:
                    pending[frame] = collections.deque((now,))
                else:
                    times.append(now)
                if now >= own.sweep_at:
                    own.sweep(now)
        messages = self._messages
        message = messages.get(frame)
        if message is None:
            if len(messages) >= _MESSAGES_KEPT:
                messages.clear()
            message = messages[frame] = self._message(frame, now)
            # the frame's own bytes, not a bytearray: a kept Message is never changed and
            # these buses only read it (udp_multicast packs it; virtual deep-copies it, and a
            # bytearray goes through copy's reduce protocol, two thirds of that copy, where
            # bytes are taken as they are: half of a virtual send and receive). Every receiver
            # still gets python-can's own Message, its data a bytearray (its __init__ does it)
            message.data = frame.data  # type: ignore[assignment]
        else:
            message.timestamp = now
        self.bus.send(message)

    def listen(self, handler: FrameHandler, on_closed: Callable[[], object] | None = None
               ) -> Callable[[], None]:
        self.handlers += (handler,)
        if on_closed is not None:
            self._on_closed.append(on_closed)
        if self._reader is None:
            self._reader = BusReader(self.bus, self._listener, self._notifier,
                                     stats=self.reading, on_closed=self._closed)

        def detach() -> None:
            handlers = list(self.handlers)
            if handler in handlers:
                handlers.remove(handler)
                self.handlers = tuple(handlers)
            if on_closed is not None and on_closed in self._on_closed:
                self._on_closed.remove(on_closed)
            if not self.handlers and self._reader is not None:
                reader, self._reader = self._reader, None
                reader.stop()

        return detach

    def listeners(self) -> list[FrameHandler]:
        return [handler for listener in BusReader.listeners_of(self.bus)
                if isinstance(listener, _PortListener) for handler in listener.port.handlers]

    def _closed(self) -> None:
        for callback in list(self._on_closed):
            callback()
