"""One SDO channel per node: one request at a time, a timeout, a bounded retry, and replies
that only ever complete the request they answer.

Real keypads drop an SDO request that arrives while they are still answering the previous one
(errata.md, field reports), so requests to one node are serialised here, whichever thread or
driver makes them.

Late replies. An SDO reply carries no transaction number: the acknowledge of ``on(4)`` (write
2001h/04) is byte for byte the acknowledge of ``off(4)``. So after a request timed out, its
reply may still come and would complete the next request to the same object. What we do:

1. On a timeout the client sends the abort CiA 301 provides (80h, 0504 0000h "SDO protocol
   timed out") and marks the channel *out of step*. The timeout error says that a write may or
   may not have been applied (``SdoTimeoutError.uncertain``).
2. Before the next request to that node, the channel gets back in step: it reads 1000h/00 and
   discards every reply until the answer to that read (an upload reply or abort for 1000h/00).
   An SDO server answers in order and never reorders (a busy one drops), so once that answer
   is in, nothing older can arrive. Replies discarded are counted in ``late_replies``. The
   read names an object no lost transfer named (1001h/00, 1018h/01 or /00 when a read of
   1000h/00 was lost: every CANopen device has them, CiA 301 §7.5.2), else the lost one's late
   reply would be taken for it.
3. A reply that comes while no request is outstanding is discarded and counted too.
4. A request that got no answer (a timeout, the resync read's too) is *owed* its reply for
   ``_OWED_FOR`` seconds: a reply naming its object that comes while no request of that object
   waits is taken for that late reply (and discarded) first. Delays on the way need not keep
   the order (a gateway's queue that empties while the device already answers directly), so
   an owed reply may come after the resync, after a new request of the same object was
   answered, or while :meth:`SdoChannel.answers` gathers: it is never a second device's.

Two devices at one node id (a wiring mistake) answer every request twice, and the second reply
completes the next request: "reply for another object". :meth:`SdoChannel.answers` tells: it
sends one read and gathers every reply to it for a while (host/device.py decides what it means).
A second device may also answer later than the whole exchange (a slow one, a loaded emulator):
its replies then come when no request waits. A reply that answers a request already answered
while in step (an initiate response or abort naming its object, CiA 301 §7.2.4.3) is a duplicate
answer: a server answers each request once and in order, so a second server sent it, or another
client asked the same (a tool on the bus; CiA 301 §7.2.4 gives an SDO channel one client). The
next request to that node tells which first: it gathers the replies to one read of 1000h for as
long as the duplicate trailed its answer (at least the timeout; :meth:`SdoChannel.answers`) and
raises :class:`SharedNodeIdError` when more than one device answers; with one, the request goes
on. Out of step (after a timeout or a reply that did not fit) the channel forgets what was
answered: a late reply is no duplicate, and a reply owed to a request that got no answer
(rule 4) is neither a duplicate answer nor a second device's answer to a gathering read.
"""

from __future__ import annotations

import contextlib
import logging
import threading
from collections.abc import Callable, Iterator
from typing import Protocol, TypeVar

from blinkcan.host.identity_errors import SharedNodeIdError, several_answer
from blinkcan.host.waits import check_wait
from blinkcan.protocol.abort import AbortCode
from blinkcan.protocol.cob import SDO_RX, SDO_TX, check_node_id, check_range
from blinkcan.protocol.frame import Frame
from blinkcan.protocol.sdo import (
    EXPEDITED_END,
    EXPEDITED_UPLOAD,
    EXPEDITED_UPLOAD_MASK,
    SCS_ABORT,
    SCS_INITIATE_DOWNLOAD,
    SCS_INITIATE_UPLOAD,
    SdoFrameError,
    multiplexer,
    parse_sdo,
    split_multiplexer,
)
from blinkcan.protocol.sdo_client import (
    DownloadTransfer,
    SdoError,
    SdoProtocolError,
    SdoTimeoutError,
    UploadTransfer,
)
from blinkcan.runtime.scheduler import Signal

log = logging.getLogger(__name__)
T = TypeVar("T", UploadTransfer, DownloadTransfer)
_new_tuple = tuple.__new__

#: the most times a request that got no reply is sent again: each try waits a whole timeout,
#: so more is a typo
MAX_SDO_RETRIES = 100
#: bytes 4-7 of an initiate upload request: reserved (CiA 301 §7.2.4.3.5)
_RESERVED = b"\x00\x00\x00\x00"
#: the command byte of an SDO abort (CiA 301 §7.2.4.3.17: ccs/scs 4)
ABORT_COMMAND = 0x80

# objects every CANopen device has (CiA 301 §7.5.2: 1000h, 1001h, 1018h/00-01): one that no
# lost request named is read to get back in step (module docstring)
#: the longest a request waits to tell a second device from another client (module docstring)
_MAX_DUPLICATE_WAIT = 5.0
#: how long a request that got no answer is owed its reply (module docstring, rule 4): far
#: longer than any delay a device or gateway adds, short enough that a reply lost for good does
#: not hide a second device for long
_OWED_FOR = 5.0
_RESYNC_MUXES = tuple(multiplexer(index, subindex) for index, subindex in
                      ((0x1000, 0), (0x1001, 0), (0x1018, 1), (0x1018, 0)))


def check_retries(retries: int) -> int:
    """``retries`` if it is a retry count, an int 0..:data:`MAX_SDO_RETRIES`; else
    TypeError/ValueError naming it, before anything is sent."""
    return check_range("retries", retries, 0, MAX_SDO_RETRIES)


class SdoHost(Protocol):
    """What an SDO channel needs of the host side of its bus (``host.bus.HostBus``)."""

    @property
    def in_handler(self) -> bool: ...

    @property
    def closed(self) -> bool: ...

    def signal(self) -> Signal: ...

    def send(self, frame: Frame) -> None: ...

    def wait(self, signal: Signal, timeout: float) -> bool: ...

    def sleep(self, seconds: float) -> None: ...

    def clock(self) -> float: ...

    def subscribe_fast(self, can_id: int, handler: Callable[[Frame, float], None]
                       ) -> Callable[[], None]: ...

    @property
    def simulated(self) -> bool: ...


class SdoChannel:
    """The client side of one node's SDO server.

    What answers a request: for the first request of a transfer, a whole SDO frame naming its
    object, or an abort (one naming another object fails the transfer); for a segment's, any
    whole SDO frame (segments name no object). Anything else (a malformed frame, a reply for
    another object: another device's, or a stale one) is not this request's answer: discarded
    and counted, the request waits on.
    """

    def __init__(self, host: SdoHost, node_id: int, timeout: float = 0.5, retries: int = 1
                 ) -> None:
        self.host = host
        self.node_id = check_node_id(node_id)  # checked once: requests are built unchecked
        self.timeout = timeout
        self.retries = check_retries(retries)
        self.late_replies = 0
        self._lock = threading.Lock()
        self._state_lock = threading.Lock()
        self._signal = host.signal()
        self._reply: bytes | None = None  # the awaited reply, once it came
        self._awaiting = False
        #: what the awaited reply must be: a whole SDO frame naming ``_wanted`` (an initiate
        #: request's object) or an abort; any whole frame (None: a segment's); or what
        #: ``_accept`` says (the resync read)
        self._wanted: bytes | None = None
        self._accept: Callable[[bytes], bool] | None = None
        self._out_of_step = False
        self._lost: set[bytes] = set()  # objects of requests whose replies may still come
        #: objects of requests that got no answer -> when each gave up (oldest first): their
        #: replies may still come (module docstring, rule 4)
        self._owed: dict[bytes, list[float]] = {}
        self._request_id = SDO_RX + node_id
        self._gathered: list[bytes] | None = None  # replies :meth:`answers` gathers
        #: objects of the initiate requests answered while in step -> when (the last time)
        self._answered: dict[bytes, float] = {}
        #: the longest a duplicate answer trailed its answer, not yet looked into (None: none)
        self._duplicate_lag: float | None = None
        host.subscribe_fast(SDO_TX + node_id, self._on_reply)

    def wake(self) -> None:
        """Wake the request waiting for its reply: the bus was shut down (it then fails)."""
        self._signal.set()

    def _on_reply(self, frame: Frame, now: float) -> None:
        """On the reader thread: the awaited reply wakes its request; anything else is
        discarded (and counted), or gathered by :meth:`answers`."""
        data = frame.data
        with self._state_lock:
            if self._awaiting and len(data) >= 8:
                wanted, accept = self._wanted, self._accept
                if (accept(data) if accept is not None else
                        wanted is None or data[1:4] == wanted or data[0] == ABORT_COMMAND):
                    self._awaiting = False
                    self._reply = data
                    if wanted is not None:  # an initiate request answered (module docstring)
                        self._answered[wanted] = now
                    self._signal.set()
                    return
            initiate = _answers_initiate(data)
            if initiate and self._owed and self._take_owed(data[1:4]):
                self.late_replies += 1  # a request that got no answer gets it now: rule 4
                log.debug("node %02Xh: late SDO reply %s discarded", self.node_id,
                          data.hex(" "))
                return
            if self._gathered is not None:
                self._gathered.append(data)
                return
            self.late_replies += 1
            answered = self._answered.get(data[1:4])
            if answered is not None and initiate:  # module docstring
                self._duplicate_lag = max(self._duplicate_lag or 0.0, now - answered)
            log.debug("node %02Xh: SDO reply %s discarded (no request awaits it)",
                      self.node_id, data.hex(" "))

    def _owe(self, mux: bytes) -> None:
        """A request of ``mux`` got no answer: its reply may still come (rule 4). Under the
        state lock."""
        self._owed.setdefault(mux, []).append(self.host.clock())

    def _take_owed(self, mux: bytes) -> bool:
        """Whether a reply naming ``mux`` is the late reply of a request that got none (and
        then it is owed no more); forgets what is owed for longer than ``_OWED_FOR``. Under the
        state lock."""
        horizon = self.host.clock() - _OWED_FOR
        for key in [key for key, times in self._owed.items() if times[-1] < horizon]:
            del self._owed[key]
        times = [when for when in self._owed.get(mux, ()) if when >= horizon]
        if not times:
            return False
        del times[0]  # the oldest request's: a server answers in order
        if times:
            self._owed[mux] = times
        else:
            del self._owed[mux]
        return True

    @contextlib.contextmanager
    def replies_also_from(self, node_id: int) -> Iterator[None]:
        """Inside: replies from ``node_id``'s SDO server count too (a device that takes a new
        node id at once acknowledges the write from it: PKP rev 1.5, errata G1)."""
        restore = self.host.subscribe_fast(SDO_TX + node_id, self._on_reply)
        try:
            yield
        finally:
            restore()

    def answers(self, index: int, subindex: int, window: float) -> list[bytes]:
        """Send one read of ``index``/``subindex`` and return every reply to it (an upload
        response or an abort for that object) heard within ``window`` seconds: one device
        answers once. Other replies heard meanwhile (late ones) are dropped."""
        if self.host.in_handler:
            raise RuntimeError("SDO transfers block: call them from your thread, not a handler")
        with self._lock:
            return self._gather(multiplexer(index, subindex), window)

    def _gather(self, mux: bytes, window: float) -> list[bytes]:
        """:meth:`answers`, holding the request lock."""
        with self._state_lock:
            self._gathered = []
            self._answered.clear()  # every reply is gathered and counted here
            self._duplicate_lag = None
        try:
            self.host.send(Frame(self._request_id, b"\x40" + mux + b"\x00\x00\x00\x00"))
            self.host.sleep(window)
        finally:
            with self._state_lock:
                gathered, self._gathered = self._gathered, None
                replies = [data for data in gathered if _answers_upload_of(data, mux)]
                if not replies:  # the read got no answer: its reply may still come (rule 4)
                    self._owe(mux)
        return replies

    def upload(self, index: int, subindex: int, *, timeout: float | None = None,
               retries: int | None = None) -> bytes:
        return self._upload(index, subindex, self.timeout if timeout is None
                            else check_wait("timeout", timeout, self.host),
                            self.retries if retries is None else check_retries(retries))

    def download(self, index: int, subindex: int, data: bytes, *, timeout: float | None = None,
                 retries: int | None = None) -> None:
        self._run(DownloadTransfer(index, subindex, data), self.timeout if timeout is None
                  else check_wait("timeout", timeout, self.host),
                  self.retries if retries is None else check_retries(retries))

    def _upload(self, index: int, subindex: int, timeout: float, retries: int) -> bytes:
        """``_run(UploadTransfer(index, subindex), timeout, retries).value``, the common case
        (in step, answered by an expedited upload response) without a transfer object: most
        reads are one expedited reply, and the transfer's calls cost more than the read. Any
        other reply, or none, goes on as the transfer's first reply (same rules, same
        errors)."""
        mux = multiplexer(index, subindex)  # checked first, as UploadTransfer checks it
        if self.host.in_handler:
            raise RuntimeError("SDO transfers block: call them from your thread, not a handler")
        with self._lock:
            if self._duplicate_lag is not None or self._out_of_step:
                return self._attempts(UploadTransfer(index, subindex), timeout, retries).value
            reply = self._exchange(b"\x40" + mux + _RESERVED, timeout, mux)
            # UploadTransfer.on_reply's first case, inlined: CiA 301 §7.2.4.3.6, an expedited
            # initiate upload response naming the object carries the value, n bytes where the
            # size is stated, else all four. _on_reply took it: eight bytes, naming the object
            # (the one reply it takes that may name another is an abort, 80h)
            if reply is not None and reply[0] & EXPEDITED_UPLOAD_MASK == EXPEDITED_UPLOAD:
                return reply[4 : EXPEDITED_END[reply[0]]]
            return self._attempts(UploadTransfer(index, subindex), timeout, retries,
                                  (reply,)).value

    def _run(self, transfer: T, timeout: float, retries: int) -> T:
        """Run ``transfer``, and a fresh one per retry; a timeout is retried, anything else
        raised."""
        if self.host.in_handler:
            raise RuntimeError("SDO transfers block: call them from your thread, not a handler")
        with self._lock:
            return self._attempts(transfer, timeout, retries)

    def _attempts(self, transfer: T, timeout: float, retries: int,
                  answered: tuple[bytes | None] | None = None) -> T:
        """:meth:`_run`, holding the request lock. ``answered``: the first attempt's first
        request was sent (in step) and got this reply (None: none in time)."""
        if answered is None and self._duplicate_lag is not None:
            self._check_shared(timeout)
        first: SdoTimeoutError | None = None
        uncertain: SdoTimeoutError | None = None  # an attempt that may have taken effect
        for attempt in range(retries + 1):
            if attempt:
                transfer = transfer.again()
            try:
                if answered is not None:
                    (reply,), answered = answered, None
                    self._go_on(transfer, timeout, reply)
                else:
                    if self._out_of_step:
                        self._resync(timeout, transfer)
                    self._transfer(transfer, timeout)
                return transfer
            except SdoTimeoutError as error:
                first = first or error
                uncertain = uncertain or (error if error.uncertain else None)
                if attempt == retries:
                    raise (uncertain or first) from None
                log.debug("node %02Xh: %s; retrying", self.node_id, error)
            except SdoError as error:
                if error.node_id is None:
                    error.node_id = self.node_id
                    error.args = (f"node {self.node_id:02X}h {error.args[0]}",)
                raise
        raise AssertionError("unreachable")

    def _check_shared(self, timeout: float) -> None:
        """After a duplicate answer: :class:`SharedNodeIdError` when more than one device
        answers a read of 1000h within the time the duplicate trailed (at least ``timeout``, at
        most ``_MAX_DUPLICATE_WAIT``; module docstring). The request is not sent then."""
        lag = self._duplicate_lag or 0.0
        window = min(max(timeout, 1.5 * lag), max(timeout, _MAX_DUPLICATE_WAIT))
        replies = self._gather(_RESYNC_MUXES[0], window)
        if len(replies) > 1:
            raise SharedNodeIdError(several_answer(len(replies), self.node_id), len(replies))

    def _exchange(self, request: bytes, timeout: float, wanted: bytes | None,
                  accept: Callable[[bytes], bool] | None = None) -> bytes | None:
        """Send ``request`` and wait for the reply it gets (see ``_wanted``); None on a
        timeout."""
        signal = self._signal
        # no lock: the reader takes a reply only while ``_awaiting`` (False here: the last
        # exchange ended under the lock), so what it checks is in place before it is set
        signal.clear()
        self._reply = None
        self._wanted = wanted
        self._accept = accept
        self._awaiting = True
        try:
            # the node id was checked and ``request`` is made here: Frame.trusted, inlined
            self.host.send(_new_tuple(Frame, (self._request_id, request, False)))
            self.host.wait(signal, timeout)
        finally:
            with self._state_lock:  # no reply is taken after this
                self._awaiting = False
                self._accept = None
                reply = self._reply
                if reply is None:  # out of step: a late reply is no duplicate (module docstring)
                    self._answered.clear()
                    if wanted is not None or accept is not None:  # a request naming an object
                        self._owe(request[1:4])  # its reply may still come (rule 4)
        if reply is None and self.host.closed:  # woken by :meth:`wake`, or timed out
            raise SdoError("the bus was shut down", self.node_id,
                           int.from_bytes(request[1:3], "little"), request[3])
        return reply

    def _transfer(self, transfer: UploadTransfer | DownloadTransfer, timeout: float) -> None:
        self._go_on(transfer, timeout, self._exchange(transfer.start(), timeout, transfer.mux))

    def _go_on(self, transfer: UploadTransfer | DownloadTransfer, timeout: float,
               reply: bytes | None) -> None:
        """The rest of ``transfer``, whose first request got ``reply`` (None: none in
        time)."""
        while True:
            if reply is None:
                self._out_of_step = True
                self._lost.add(transfer.mux)
                self.host.send(Frame(self._request_id,
                                     transfer.abort_request(AbortCode.SDO_PROTOCOL_TIMED_OUT)))
                raise self._timeout(transfer, timeout)
            try:
                request = transfer.on_reply(reply)
            except SdoProtocolError:
                # CiA 301 §7.2.4.3.17: a reply that does not fit aborts the transfer; the
                # server's own reply may still come, so get back in step before the next request
                self._out_of_step = True
                with self._state_lock:
                    self._answered.clear()
                    self._lost.add(transfer.mux)
                self.host.send(Frame(self._request_id, transfer.abort_request(
                    AbortCode.COMMAND_SPECIFIER_INVALID)))
                raise
            if request is None:
                return
            reply = self._exchange(request, timeout, None)  # segments name no object

    def _resync(self, timeout: float, transfer: UploadTransfer | DownloadTransfer) -> None:
        """Read 1000h/00 (or another object every device has, that no lost request named),
        discarding every reply until its own (see the module docstring)."""
        mux = next((mux for mux in _RESYNC_MUXES if mux not in self._lost), _RESYNC_MUXES[0])
        request = b"\x40" + mux + b"\x00\x00\x00\x00"

        def answers_resync(data: bytes) -> bool:
            return _answers_upload_of(data, mux)

        if self._exchange(request, timeout, None, answers_resync) is None:
            index, subindex = split_multiplexer(mux)
            raise SdoTimeoutError(
                f"no reply within {timeout} s (node {self.node_id:02X}h did not answer a read "
                f"of {index:04X}h/{subindex:02X} after an earlier timeout; nothing was sent "
                "for this request)", self.node_id, transfer.index, transfer.subindex)
        self._out_of_step = False
        self._lost.clear()

    def _timeout(self, transfer: UploadTransfer | DownloadTransfer, timeout: float
                 ) -> SdoTimeoutError:
        if isinstance(transfer, DownloadTransfer):
            error = SdoTimeoutError(
                f"no reply within {timeout} s: the write may or may not have been applied",
                self.node_id, transfer.index, transfer.subindex)
            error.uncertain = True
            return error
        return SdoTimeoutError(f"no reply within {timeout} s", self.node_id, transfer.index,
                               transfer.subindex)


def _answers_initiate(data: bytes) -> bool:
    """Whether ``data`` can answer an initiate request (for the object it names): an upload or
    download initiate response, or an abort (CiA 301 §7.2.4.3.3, .6, .17)."""
    return len(data) >= 8 and data[0] >> 5 in (SCS_INITIATE_UPLOAD, SCS_INITIATE_DOWNLOAD,
                                               SCS_ABORT)


def _answers_upload_of(data: bytes, mux: bytes) -> bool:
    """A reply (eight bytes) that answers a read of ``mux``: its upload response or abort."""
    try:
        return parse_sdo(data).answers_upload_of(mux)
    except SdoFrameError:
        return False


class SdoClient:
    """A driver's handle on a node's shared :class:`SdoChannel`, with its own timeout and
    retries (so one driver or ``scan`` never changes another's)."""

    def __init__(self, channel: SdoChannel, timeout: float, retries: int) -> None:
        self.channel = channel
        self.node_id = channel.node_id
        self.timeout = timeout
        self.retries = check_retries(retries)

    def upload(self, index: int, subindex: int, *, timeout: float | None = None,
               retries: int | None = None) -> bytes:
        return self.channel._upload(index, subindex, self.timeout if timeout is None
                                    else check_wait("timeout", timeout, self.channel.host),
                                    self.retries if retries is None else
                                    check_retries(retries))

    def download(self, index: int, subindex: int, data: bytes, *, timeout: float | None = None,
                 retries: int | None = None) -> None:
        self.channel._run(DownloadTransfer(index, subindex, data), self.timeout if timeout is
                          None else check_wait("timeout", timeout, self.channel.host),
                          self.retries if retries is None else check_retries(retries))
