"""Frames -> events for both devices, with a generic CANopen fallback. Pure: no I/O, no clock.

Which node is which device comes from the caller (``{0x15: "keypad"}``) or is learned from the
bus: an SDO reply of 1000h (device type) or 100Bh (model) names the model, and so does a PDO
only one registered model sends (devices/registry.py sole_senders) at a node assumed or heard
as a CANopen node (its heartbeat or boot-up, an SDO reply from it, or an NMT command addressed
to it). A frame before the one that names the model keeps
the meaning it had. Everything a device means is read from its
description in ``devices/`` (object names, PDO layouts).

Per node the decoder remembers what it needs to say what changed: the keys held, and the SDO
transfer in progress (segmented uploads are reassembled into one value).
"""

from __future__ import annotations

import json
from collections.abc import Callable
from decimal import Decimal
from enum import Enum
from typing import Any, NamedTuple

import orjson

from blinkcan.decode.describers import (  # listing, mask_listing, numbers: kept importable here
    keyed_signal,
    listing,
    mask_listing,
    numbers,
    pdo_renderings,
)
from blinkcan.decode.j1939 import J1939KeypadDecoder
from blinkcan.decode.nodes import DevicesByNode, split_devices
from blinkcan.devices.colours import BacklightColour
from blinkcan.devices.keypad_j1939 import DEFAULT_ADDRESS as J1939_DEFAULT_ADDRESS
from blinkcan.devices.model import DeviceDescription
from blinkcan.devices.objects import ObjectEntry
from blinkcan.devices.pdo import PdoLayout
from blinkcan.devices.registry import identify, sole_senders
from blinkcan.protocol.abort import describe_abort
from blinkcan.protocol.cob import HEARTBEAT, NMT, SDO_RX, SDO_TX, SYNC
from blinkcan.protocol.frame import Frame
from blinkcan.protocol.nmt import NmtCommand, NmtState, parse_nmt
from blinkcan.protocol.sdo import (
    CCS_ABORT,
    CCS_DOWNLOAD_SEGMENT,
    CCS_INITIATE_DOWNLOAD,
    CCS_INITIATE_UPLOAD,
    CCS_UPLOAD_SEGMENT,
    EXPEDITED_UPLOAD_COMMAND,
    SCS_ABORT,
    SCS_DOWNLOAD_SEGMENT,
    SCS_INITIATE_UPLOAD,
    SCS_UPLOAD_SEGMENT,
    SEGMENTED_UPLOAD_RESPONSE,
    parse_sdo,
)
from blinkcan.protocol.sdo_client import QUIRK_ACKNOWLEDGES, SdoError, UploadTransfer

_UPLOAD_SIZES = {command: size for size, command in EXPEDITED_UPLOAD_COMMAND.items()}
#: the SDO functions of an 11-bit identifier (CiA 301 §7.2.4): server to client, client to server
_SDO_FUNCTIONS = frozenset({SDO_TX, SDO_RX})
#: requests that name an object (CiA 301 §7.2.4.3): initiate download, upload, abort
_INITIATE_REQUESTS = frozenset({CCS_INITIATE_DOWNLOAD, CCS_INITIATE_UPLOAD, CCS_ABORT})
_NMT_TEXT = {
    NmtCommand.START: "start", NmtCommand.STOP: "stop",
    NmtCommand.ENTER_PRE_OPERATIONAL: "enter pre-operational",
    NmtCommand.RESET_NODE: "reset node", NmtCommand.RESET_COMMUNICATION: "reset communication",
}
_STATE_TEXT = {NmtState.STOPPED: "stopped", NmtState.OPERATIONAL: "operational",
               NmtState.PRE_OPERATIONAL: "pre-operational"}
#: cached JSON bodies kept at most (the oldest half goes when full): a few MB at worst
_JSON_CACHE_SIZE = 16_384
#: a route's JSON stops being cached when, after this many misses, under 1 in 4 lookups hit
_CACHE_TRIAL = 512
#: 29-bit identifiers of other ECUs kept (then they start over): a J1939 bus has a few hundred
_FOREIGN_KEPT = 512
#: SDO events kept (then they start over)
_SDO_KEPT = 4096
#: objects whose value may name a node's model (Decoder._learn): their events are not kept
_IDENTITY = frozenset({0x1000, 0x100B})
#: J1939 keypad frames whose meaning is kept (then they start over)
_J1939_KEPT = 4096
#: lines a PDO or heartbeat writer keeps by data (then they start over): a few kB a route
_WRITTEN_KEPT = 64
#: routes kept: every 11-bit identifier, and 29-bit ones the J1939 keypad may use up to this
_ROUTES_KEPT = 2048 + 256
_dumps = orjson.dumps
_standard_encode = json.JSONEncoder(separators=(",", ":")).encode


def _stamp(time: float) -> str:
    """A time as ``decode --json`` writes it on every line: a plain decimal (what people grep
    for; never ``2e-05``) of the shortest digits that read back as the same float. orjson
    writes that (Ryu's digits) for 1e-5 <= |time| < 1e16, in a third of repr's cost (a
    float's text took a fifth of a line's); the rare time outside, with repr's digits."""
    return _dumps(time).decode() if 1e-5 <= time < 1e16 else json_time(time)


def json_times(times: list[float]) -> list[str]:
    """:func:`_stamp` of each of ``times``, in one orjson call where all are in its range
    (a block of a log: the same digits, a tenth of the cost)."""
    if times and min(times) >= 1e-5 and max(times) < 1e16:
        return _dumps(times)[1:-1].decode().split(",")
    return list(map(json_time, times))


def json_time(time: float) -> str:
    """:func:`_stamp` for any finite time (negative ones included)."""
    if 1e-5 <= abs(time) < 1e16:
        return _dumps(time).decode()
    text = format(Decimal(repr(time)), "f")  # repr: the shortest round-trip digits
    return text if "." in text else text + ".0"


def _encode_text(text: str) -> str:
    return orjson.dumps(text).decode()


_TIME_FIELD = '{"time":'
_ZERO_TIME = len(_TIME_FIELD + "0")


def _encode(document: dict[str, Any]) -> str:
    """Compact JSON; orjson (the same text, ten times faster), the standard encoder for what
    orjson refuses; a document's time (its first field) as :func:`_stamp` writes it."""
    time = document.get("time")
    if type(time) is float and not 1e-5 <= time < 1e16 and not -1e16 < time <= -1e-5 \
            and next(iter(document)) == "time":
        rest = _encode({**document, "time": 0})
        return _TIME_FIELD + json_time(time) + rest[_ZERO_TIME:]
    try:
        return orjson.dumps(document).decode()
    except TypeError:
        if type(time) is float:
            rest = _standard_encode({**document, "time": 0})
            return _TIME_FIELD + json_time(time) + rest[_ZERO_TIME:]
        return _standard_encode(document)


#: a log item's JSON (an event, an unreadable line) as ``decode --json`` writes it
encode_json = _encode


class Kind(str, Enum):
    NMT = "nmt"
    SYNC = "sync"
    BOOT_UP = "boot-up"
    HEARTBEAT = "heartbeat"
    PDO = "pdo"
    SDO_READ = "sdo-read"
    SDO_WRITE = "sdo-write"
    SDO_VALUE = "sdo-value"
    SDO_WRITTEN = "sdo-written"
    SDO_SEGMENT = "sdo-segment"
    SDO_ABORT = "sdo-abort"
    J1939 = "j1939"
    REMOTE = "remote"
    ERROR = "error"
    FRAME = "frame"


_NO_FIELDS: dict[str, Any] = {}  # shared, never written
#: what a frame that means nothing costs: its event's (text, node, device), its JSON line
#: before and after the data, and its event as text (Decoder._keep_raw)
_Raw = tuple[tuple[str, "int | None", "str | None", dict[str, Any]], str, str, str]
_new_tuple = tuple.__new__
#: a route's JSON line after the time, from the frame's data (None: the Event's to write)
_Writer = Callable[[bytes], "str | None"]
_BOOT_UP = bytes((NmtState.BOOT_UP,))


class Event(NamedTuple):
    """What one frame meant: immutable, equal by value. ``text`` is the one-line form,
    :meth:`to_json` the JSON form; ``fields`` holds the decoded values (read-only).
    A tuple underneath: a decoder makes one per frame, a million for a large log."""

    time: float
    frame: Frame
    kind: Kind
    text: str
    node_id: int | None = None
    device: str | None = None
    fields: dict[str, Any] = _NO_FIELDS

    def __str__(self) -> str:
        who = f"{self.device or 'node'} {self.node_id:02X}h: " if self.node_id is not None else ""
        return who + self.text

    def to_json(self) -> dict[str, Any]:
        frame = self.frame
        return {
            "time": self.time,
            "id": frame.can_id,
            "extended": frame.extended,
            "data": frame.data.hex(),
            "kind": self.kind,  # a str: JSON writes its value
            "node": self.node_id,
            "device": self.device,
            "text": str(self),
            **self.fields,
        }


#: an SDO transfer with no frame for this long is over (its client gave up); its state goes
TRANSFER_IDLE_S = 2.0
#: a segmented transfer longer than this is no longer followed (no object of these devices is
#: a tenth of it; a generic node's domain could be anything)
TRANSFER_MAX_BYTES = 4096


class _Transfer:
    """A node's SDO transfer as the bus shows it. A read is followed by the client's own
    state machine (protocol/sdo_client.py UploadTransfer) fed the replies the client gets,
    made when the first reply that is not a kept one comes (most reads are answered by a
    reply seen before: Decoder._sdo_seen); a write by the count of bytes its segments
    carried."""

    __slots__ = ("_upload", "entry", "index", "last", "subindex", "writing", "written")

    def __init__(self, index: int, subindex: int, entry: ObjectEntry | None, writing: bool,
                 last: float = 0.0) -> None:
        self.index, self.subindex, self.entry = index, subindex, entry
        self.writing, self.last, self.written = writing, last, 0
        self._upload: UploadTransfer | None = None

    @property
    def upload(self) -> UploadTransfer | None:
        """The read's state machine (None for a write)."""
        if self._upload is None and not self.writing:
            self._upload = UploadTransfer(self.index, self.subindex)
        return self._upload


class Decoder:
    """Decode frames of one bus. ``devices`` maps node ids to "keypad", "keybox" (optionally
    "keypad@1.1") or descriptions, and J1939 addresses (``"j1939:0x30"``) to models that have
    J1939 (decode/nodes.py; none named: 21h, §5); ``learn`` names unknown nodes from identity
    traffic and from PDOs only one model sends; ``assumed``: the CANopen ``devices`` are a
    guess (no --device given), which that learning corrects. ValueError for a device it
    cannot name."""

    def __init__(self, devices: DevicesByNode | None = None,
                 learn: bool = True, assumed: bool = False) -> None:
        self.learn = learn
        named = split_devices(devices)
        self.devices: dict[int, DeviceDescription] = named.canopen
        self._keys: dict[int, int] = {}
        self._transfers: dict[int, _Transfer] = {}
        self._routes: dict[tuple[int, bool], Callable[[Frame, float], Event]] = {}
        #: routes whose event depends on the frame's bytes alone (no state read or written)
        self._pure: set[tuple[int, bool]] = set()
        #: key-state routes: (node, shift, mask) of the keys in the frame
        self._keyed: dict[tuple[int, bool], tuple[int, int, int]] = {}
        self._json_bodies: dict[object, str] = {}
        #: 11-bit identifiers whose JSON line after the time is written from the data alone,
        #: without an Event (PDOs, heartbeats: most of the devices' frames); None from one for
        #: a frame it leaves to the Event (a PDO too short)
        self._writers: dict[int, _Writer] = {}
        #: the same for the one-line text (:meth:`text`): PDOs
        self._text_writers: dict[int, Callable[[bytes], str]] = {}
        #: per route: [cache hits, cache misses]; routes whose frames rarely repeat go uncached
        self._cache_stats: dict[tuple[int, bool], list[int]] = {}
        self._uncached: set[tuple[int, bool]] = set()
        #: nodes named from 1000h alone (two keypads share it) or assumed: 100Bh or a PDO
        #: only one model sends may still correct them
        self._guessed: set[int] = set(self.devices) if assumed else set()
        #: nodes that showed they are CANopen nodes (Decoder._hear)
        self._heard: set[int] = set()
        #: unknown nodes that sent a PDO only one model sends, before any heartbeat of theirs:
        #: another ECU may use that identifier, so the model is named once the node is heard
        self._unconfirmed: dict[int, DeviceDescription] = {}
        #: keypads in J1939 mode, by address (decode/j1939.py)
        self.j1939 = J1939KeypadDecoder(() if named.j1939 else (J1939_DEFAULT_ADDRESS,),
                                        named.j1939)
        #: 11-bit identifiers no device's frame uses (other ECUs): their event's (text, node,
        #: device) and their JSON line before and after the data; a lookup is all they cost
        self._raw_standard: dict[int, _Raw] = {}
        #: 29-bit identifiers of PGNs the keypad never uses (other ECUs'), with their text
        self._foreign: dict[int, str] = {}
        #: their JSON line around time and data (raw_json), made once
        self._foreign_json: dict[int, tuple[str, str]] = {}
        #: SDO events that the same frame makes again (an upload request; an expedited upload
        #: response in the same transfer): [the event's text, node, device, fields; its JSON
        #: body after the time, once written; the transfer a request opens; what a batch
        #: reader made of it (its own: :meth:`kept_entry`)]
        self._kept: dict[object, list[Any]] = {}
        #: the kept entry the last decoded SDO frame used (json_line writes its JSON once)
        self._served: list[Any] | None = None
        #: J1939 keypad frames' events as kept SDO ones are, valid while the count of keypad
        #: addresses they were decoded with (the entry's third item) holds; the fourth, a
        #: batch reader's
        self._j1939_known: dict[Frame, list[Any]] = {}

    def device(self, node_id: int) -> DeviceDescription | None:
        return self.devices.get(node_id)

    def decode(self, frame: Frame, time: float = 0.0) -> Event:
        """The event one frame makes (every frame makes one)."""
        if frame[2]:  # another ECU's frame is a lookup (a frame is a tuple underneath)
            text = self._foreign.get(frame[0])
            if text is not None:  # the Event built as a tuple: its fields are all given
                return _new_tuple(Event, (time, frame, Kind.FRAME, text, None, None,
                                          _NO_FIELDS))
        else:
            raw = self._raw_standard.get(frame[0])
            if raw is not None:
                return _new_tuple(Event, (time, frame, Kind.FRAME, *raw[0]))
        route = self._routes.get((frame.can_id, frame.extended))
        if route is None:
            route = self._route(frame)
            if not frame.extended:  # at most 2048 standard identifiers: the cache is bounded
                self._routes[frame.can_id, frame.extended] = route
            elif len(self._routes) < _ROUTES_KEPT and self.j1939.concerns(frame.can_id):
                self._routes[frame.can_id, True] = route  # the keypad PGNs' ids, up to a bound
        return route(frame, time)

    def undecoded(self, can_id: int, extended: bool) -> tuple[str, int | None, str | None] | None:
        """(text, node, device) of the event every frame of this identifier makes, where it
        means nothing here (another ECU's: kind FRAME, no fields) and was seen before; None
        otherwise (then :meth:`decode` it). For a batch reader (the fleet's columns): such a
        frame, most of a fleet's log, costs a lookup, no Frame and no Event; the decoder's
        state does not depend on these frames."""
        if extended:
            text = self._foreign.get(can_id)
            return None if text is None else (text, None, None)
        raw = self._raw_standard.get(can_id)
        return None if raw is None else (raw[3], raw[0][1], raw[0][2])

    def raw_json(self, can_id: int, extended: bool) -> tuple[str, str] | None:
        """(what follows the time, what follows the data) of the JSON line every frame of
        this identifier makes (:meth:`json_line`: ``'{"time":' + time + first + data hex +
        second``), where it means nothing here (:meth:`undecoded`); None otherwise. For a
        batch writer (decode --json a block at a time): such a frame costs a lookup."""
        if extended:
            text = self._foreign.get(can_id)
            if text is None:
                return None
            parts = self._foreign_json.get(can_id)
            if parts is None:  # the text has no character JSON escapes (Decoder._extended)
                if len(self._foreign_json) >= _FOREIGN_KEPT:
                    self._foreign_json.clear()
                parts = self._foreign_json[can_id] = (
                    f',"id":{can_id},"extended":true,"data":"',
                    f'","kind":"frame","node":null,"device":null,"text":"{text}"}}')
            return parts
        raw = self._raw_standard.get(can_id)
        return None if raw is None else (raw[1], raw[2])

    def repeat_state(self, can_id: int, extended: bool, data: bytes) -> tuple[int, ...] | None:
        """For a batch reader that keeps what a frame made: where the frame's event depends on
        nothing but its bytes, the devices' models and the state returned, and it changes no
        state but that, the state; None otherwise (not routed yet; SDO: time and transfers).
        A frame whose state is the same before and after it is then one that makes the same
        event again from the same state, and changes nothing."""
        key = (can_id, extended)
        if key not in self._routes:
            return None
        if extended:  # a J1939 keypad PGN's: its meaning depends on the keypads' addresses
            return (len(self.j1939.addresses),)  # (only ever added: Decoder._extended)
        node = can_id & 0x7F
        if key in self._keyed or (can_id & 0x780 == HEARTBEAT and data[:1] == _BOOT_UP):
            return node, self._keys.get(node, 0)  # read, or reset by a boot-up (PKP §10)
        return () if key in self._pure else None

    def is_kept(self, event: Event) -> bool:
        """Whether the event, just decoded, is one the decoder keeps and makes again (an SDO
        read or value seen before, a J1939 keypad frame's): every event made from the same
        kept entry has the same ``fields`` object, and is the same but for time and frame.
        A batch reader may keep what it made of such an event by its fields."""
        return self.kept_entry(event) is not None

    def kept_entry(self, event: Event) -> list[Any] | None:
        """The entry the decoder keeps that the event, just decoded (or made again by
        :meth:`kept_event` or :meth:`kept_sdo`), was made from; None for any other event.
        Its last item is the batch reader's (None until it sets it): what it made of the
        entry, kept as long as the decoder keeps the entry, and gone with it."""
        served = self._served
        return served if served is not None and served[0][3] is event.fields else None

    def kept_event(self, can_id: int, extended: bool, data: bytes, time: float) -> Event | None:
        """For a batch reader that keeps what it made of kept events (:meth:`is_kept`): where
        this frame makes a kept event again (an SDO read or value seen before, a J1939 keypad
        frame's with the same keypad addresses), that event, the decoder's state moved as
        :meth:`decode` moves it; None otherwise, nothing moved (then decode the frame)."""
        if extended:
            frame = _new_tuple(Frame, (can_id, data, True))
            known = self._j1939_known.get(frame)
            if known is None or known[2] != len(self.j1939.addresses):  # (Decoder._extended)
                return None
            self._served = known
            return _new_tuple(Event, (time, frame, Kind.J1939, *known[0]))
        seen = self.kept_sdo(can_id, data, time)
        if seen is None:
            return None
        return _new_tuple(Event, (time, _new_tuple(Frame, (can_id, data, False)), seen[0],
                                  *seen[1][0]))

    def kept_sdo(self, can_id: int, data: bytes, time: float) -> tuple[Kind, list[Any]] | None:
        """:meth:`kept_event` of an 11-bit frame without the Event: where it makes a kept SDO
        event again, its kind and the kept entry (the event's text, node, device and
        ``fields`` are the entry's first item: the same objects each time), the decoder's
        state moved as :meth:`decode` moves it; None otherwise, nothing moved."""
        if can_id & 0x780 not in _SDO_FUNCTIONS or not can_id & 0x7F:  # Decoder._route: SDO
            return None
        seen = self._sdo_seen(_new_tuple(Frame, (can_id, data, False)), time)
        if seen is not None:
            self._served = seen[1]
        return seen

    def key_signal(self, can_id: int) -> tuple[int, int, int] | None:
        """(node, shift, mask) of the keys in the frames of an 11-bit key-state PDO
        identifier decoded before (PKP §10: their meaning depends on the keys held before;
        the mask is the node's keys); None for any other identifier."""
        return self._keyed.get((can_id, False))

    def keys_held(self, node: int) -> int:
        """The keys of a node the decoder holds down (a mask, bit 0 is key 1): what its last
        key state said (PKP §10), none after its boot-up."""
        return self._keys.get(node, 0)

    def hold_keys(self, node: int, keys: int) -> None:
        """For a batch reader that keeps what a key-state frame made (by :meth:`key_signal`'s
        keys and :meth:`keys_held` before it): the keys that frame leaves held, as
        :meth:`decode` would have left them."""
        self._keys[node] = keys

    def text(self, frame: Frame, time: float = 0.0) -> str:
        """``str(decode(frame, time))``: another ECU's frame is a lookup, a PDO's text is
        written without an Event."""
        if frame[2]:
            text = self._foreign.get(frame[0])
            if text is not None:
                return text
        else:
            raw = self._raw_standard.get(frame[0])
            if raw is not None:
                return raw[3]
            writer = self._text_writers.get(frame[0])
            if writer is not None:  # a PDO: its text without the Event (Decoder._pdo_routes)
                return writer(frame[1])
        return str(self.decode(frame, time))

    def json_line(self, frame: Frame, time: float = 0.0) -> str:
        """``json.dumps(decode(frame, time).to_json())``, fast for frames seen before.

        Logs are mostly repetition (heartbeats, periodic PDOs). Where a frame's meaning
        depends on its bytes alone, the JSON after the time is kept and reused, for as long as
        that route's frames do repeat. PDOs write their line without building an Event.
        """
        can_id, data, extended = frame
        rest = self.json_rest(can_id, extended, data, time)
        if rest is not None:
            return f'{{"time":{_stamp(time)}{rest}'
        if extended:
            self._served = None
            return self._line_of(self.decode(frame, time), time)
        if can_id & 0x780 in _SDO_FUNCTIONS and can_id & 0x7F:  # Decoder._route: SDO
            self._served = None  # not one seen before (json_rest)
            return self._line_of(self._sdo_new(frame, time), time)
        key = (can_id, extended)
        keyed = self._keyed.get(key)
        cache_key: object = frame
        cached = key not in self._uncached
        if cached:
            if keyed is not None:  # a key state means the same after the same previous keys
                node, shift, mask = keyed
                cache_key = (frame, self._keys.get(node, 0))
                body = self._json_bodies.get(cache_key)
                if body is not None:
                    self._keys[node] = (int.from_bytes(frame.data, "little") >> shift) & mask
                    self._cache_stats[key][0] += 1
                    return f'{{"time":{_stamp(time)},{body}'
            else:
                body = self._json_bodies.get(frame)
                if body is not None:
                    self._cache_stats[key][0] += 1
                    return f'{{"time":{_stamp(time)},{body}'
        self._served = None
        event = self.decode(frame, time)
        line, kind = self._line_of(event, time), event.kind
        if cached and can_id not in self._writers and (
                (key in self._pure and kind is not Kind.BOOT_UP) or (
                keyed is not None and kind is Kind.PDO)):
            self._remember(key, cache_key, time, line)
        return line

    def json_rest(self, can_id: int, extended: bool, data: bytes, time: float) -> str | None:
        """What follows ``{"time":`` and the time in :meth:`json_line`'s line, where it is
        written without an Event: another ECU's frame (:meth:`raw_json`), a device's PDO or
        heartbeat (from its data alone: Decoder._writers), an SDO or J1939 keypad frame that
        makes a kept event again; None for any other frame (then :meth:`json_line` it), the
        decoder's state untouched. For a batch writer that writes a block's times at once
        (decode --json): most frames cost a lookup and a describer, no Frame, no Event."""
        if extended:
            text = self._foreign.get(can_id)
            if text is not None:  # the text has no character JSON escapes
                parts = self._foreign_json.get(can_id) or self.raw_json(can_id, True)
                if parts is not None:
                    return f"{parts[0]}{data.hex()}{parts[1]}"
            known = self._j1939_known.get(_new_tuple(Frame, (can_id, data, True)))
            if known is not None and known[1] is not None and \
                    known[2] == len(self.j1939.addresses):  # (Decoder._extended)
                body: str = known[1]
                return "," + body
            return None
        raw = self._raw_standard.get(can_id)
        if raw is not None:  # a frame no device sends: its line around time and data
            return f"{raw[1]}{data.hex()}{raw[2]}"
        writer = self._writers.get(can_id)
        if writer is not None:
            return writer(data)
        if can_id & 0x780 in _SDO_FUNCTIONS and can_id & 0x7F:  # Decoder._route: SDO
            frame = _new_tuple(Frame, (can_id, data, False))
            seen = self._sdo_seen(frame, time)
            if seen is None:
                return None
            kind, kept = seen
            written: str | None = kept[1]
            if written is None:  # its JSON after the time, written once (_line_of)
                self._served = kept
                line = self._line_of(_new_tuple(Event, (1.0, frame, kind, *kept[0])), 1.0)
                written = kept[1]
                if written is None:
                    return line[len(_TIME_FIELD + "1.0"):]
            return "," + written
        return None

    def _line_of(self, event: Event, time: float) -> str:
        """The event's JSON line; where it is a kept one (``_served``: an SDO or J1939 event
        the same frame makes again), its JSON after the time is written once."""
        served = self._served
        if served is None or served[0][3] is not event.fields:
            return _encode(event.to_json())
        body = served[1]
        if body is not None:
            return f'{{"time":{_stamp(time)},{body}'
        line = _encode(event.to_json())
        prefix = f'{{"time":{_stamp(time)},'
        if line.startswith(prefix):
            served[1] = line[len(prefix):]
        return line

    def _remember(self, key: tuple[int, bool], cache_key: object, time: float, line: str
                  ) -> None:
        prefix = f'{{"time":{_stamp(time)},'
        if not line.startswith(prefix):
            return
        stats = self._cache_stats.setdefault(key, [0, 0])
        stats[1] += 1
        if stats[1] >= _CACHE_TRIAL and stats[0] * 4 < stats[1] + stats[0]:
            self._uncached.add(key)  # its frames rarely repeat: caching costs more than it saves
            return
        bodies = self._json_bodies
        if len(bodies) >= _JSON_CACHE_SIZE:
            for old in list(bodies)[: _JSON_CACHE_SIZE // 2]:  # dicts keep insertion order
                del bodies[old]
        bodies[cache_key] = line[len(prefix):]

    def decode_other(self, kind: str, time: float, can_id: int, extended: bool, dlc: int,
                     data: bytes, description: str) -> Event:
        """The event of a frame that is not a classic data frame, by its ``kind``
        (formats.logs.frame_kind): an error frame, a remote frame, CAN FD (not decoded), or one
        no classic frame can be (a standard id over 7FFh); ``description`` names the frame."""
        if kind == "error":
            return error_event(time, can_id, data)
        if kind == "remote":
            return self.decode_remote(can_id, extended, dlc, time)
        frame = Frame.trusted(can_id, data[:8], extended)
        if kind == "fd":
            return Event(time, frame, Kind.FRAME,
                         f"{description}, {len(data)} bytes (CAN FD is not decoded)")
        return Event(time, frame, Kind.FRAME, f"{description}: not a valid classic CAN frame")

    def decode_remote(self, can_id: int, extended: bool, dlc: int, time: float = 0.0) -> Event:
        """A remote (RTR) frame: on 700h + node it is node guarding (CiA 301 7.2.8.3.2.1)."""
        frame = Frame.trusted(can_id, b"", extended)
        node = can_id & 0x7F
        if not extended and can_id & 0x780 == HEARTBEAT and node:
            return Event(time, frame, Kind.REMOTE, "node guarding request", node,
                         self._who(node), {"dlc": dlc})
        ident = f"{can_id:08X}h" if extended else f"{can_id:03X}h"
        return Event(time, frame, Kind.REMOTE, f"remote request {ident}, DLC {dlc}",
                     fields={"dlc": dlc})

    # -- routing ----------------------------------------------------------------------------------

    def _route(self, frame: Frame) -> Callable[[Frame, float], Event]:
        key = (frame.can_id, frame.extended)
        if frame.extended:
            return self._extended  # never cached: 2**29 identifiers would not be bounded
        self._pure.add(key)  # every route below but SDO and the key state is pure
        can_id = frame.can_id
        if can_id == NMT:
            return self._nmt
        if can_id == SYNC:
            return lambda f, t: Event(t, f, Kind.SYNC, "SYNC")
        function, node = can_id & 0x780, can_id & 0x7F
        if function == HEARTBEAT and node:
            self._hear(node)
            self._writers[can_id] = self._heartbeat_writer(can_id)
            return self._heartbeat  # its boot-up resets key state: never cached (json_line)
        if function in (SDO_TX, SDO_RX) and node:
            self._pure.discard(key)
            return self._sdo
        if node:
            self._learn_sender(can_id, node)
        device = self.devices.get(node)
        if device is not None:
            for layout in device.pdos:
                if layout.cob_id(node) == can_id:
                    keyed = keyed_signal(layout)
                    if keyed is not None:  # its meaning depends on the keys held before
                        self._pure.discard(key)
                        shift, mask = keyed
                        self._keyed[key] = (node, shift, mask & ((1 << device.face.keys) - 1))
                    route, writer, self._text_writers[can_id] = self._pdo_routes(
                        layout, node, device)
                    if writer is not None:
                        self._writers[can_id] = writer
                    return route
        return self._unknown

    def _keep_raw(self, event: Event) -> None:
        """Remember the 11-bit id of a frame that means nothing here (its text does not depend
        on its data): the next one is a lookup. The JSON around time and data is to_json's."""
        line = _encode({**event.to_json(), "time": 0, "data": ""})
        head, _, tail = line.partition(',"data":""')
        self._raw_standard[event.frame.can_id] = (
            (event.text, event.node_id, event.device, _NO_FIELDS),
            head[len('{"time":0'):] + ',"data":"', '"' + tail, str(event))

    def _hear(self, node: int) -> None:
        """``node`` showed it is a CANopen node: a heartbeat or boot-up (CiA 301 §7.2.8.3), an
        SDO reply (§7.2.4), or an NMT command addressed to it (§7.2.8.3.1: the master runs it
        as one). A model that a PDO only it sends named there before (``_unconfirmed``) is now
        the node's model, for the frames from here on."""
        if node in self._heard:
            return
        self._heard.add(node)
        sender = self._unconfirmed.pop(node, None)
        if sender is not None and self.devices.get(node) is None:
            self.devices[node] = sender
            self._forget_routes(node)

    def _forget_routes(self, node: int) -> None:
        """A node's model became known: its routes and their cached JSON change."""
        for can_id in [i for i in self._raw_standard if i & 0x7F == node]:
            del self._raw_standard[can_id]
        for key in [k for k in self._routes if not k[1] and k[0] & 0x7F == node]:
            del self._routes[key]
            self._pure.discard(key)
            self._keyed.pop(key, None)
            self._writers.pop(key[0], None)
            self._text_writers.pop(key[0], None)
            self._cache_stats.pop(key, None)
            self._uncached.discard(key)
        self._json_bodies.clear()
        self._kept.clear()

    def _who(self, node: int) -> str | None:
        device = self.devices.get(node)
        return device.kind if device is not None else None

    # -- services ---------------------------------------------------------------------------------

    def _nmt(self, frame: Frame, time: float) -> Event:
        request = parse_nmt(frame)  # CiA 301 §7.2.8.3.1: command byte, node id (0: all)
        data = frame.data
        if request is not None:
            text, node = _NMT_TEXT[request.command], request.node_id
            if node:
                self._hear(node)
        elif len(data) < 2:
            return Event(time, frame, Kind.FRAME, "NMT frame too short")
        else:  # PKP §7 (errata P12): the keypad's legacy 00h is a stop
            text = "stop (legacy 00h)" if data[0] == 0 else f"command {data[0]:02X}h"
            node = data[1]
        target = "all nodes" if node == 0 else f"{self._who(node) or 'node'} {node:02X}h"
        return Event(time, frame, Kind.NMT, f"NMT {text}, {target}",
                     fields={"command": text, "target": node})

    def _heartbeat(self, frame: Frame, time: float) -> Event:
        node = frame.can_id & 0x7F
        device = self._who(node)
        if not frame.data:
            return Event(time, frame, Kind.FRAME, "empty heartbeat", node, device)
        code = frame.data[0]
        if code == NmtState.BOOT_UP:
            self._keys.pop(node, None)
            return Event(time, frame, Kind.BOOT_UP, "boot-up", node, device)
        state = _STATE_TEXT.get(code, f"state {code:02X}h")  # type: ignore[call-overload]
        return Event(time, frame, Kind.HEARTBEAT, f"heartbeat, {state}", node, device,
                     {"state": state})

    def _extended(self, frame: Frame, time: float) -> Event:
        addresses = self.j1939.addresses
        known = self._j1939_known.get(frame)
        if known is not None and known[2] == len(addresses):  # the same addresses known
            self._served = known
            return _new_tuple(Event, (time, frame, Kind.J1939, *known[0]))
        before = len(addresses)  # keypad addresses are only ever added
        meaning = self.j1939.decode(frame)
        if meaning is None:
            event = Event(time, frame, Kind.FRAME, f"extended frame {frame.can_id:08X}h")
            if not self.j1939.concerns(frame.can_id):  # never the keypad's: skip it by id
                if len(self._foreign) >= _FOREIGN_KEPT:
                    self._foreign.clear()
                self._foreign[frame.can_id] = event.text
            return event
        parts = (meaning.text, meaning.address, "keypad" if meaning.keypad else None,
                 {"protocol": "j1939", **meaning.fields})
        known_frames = self._j1939_known
        # nothing learned: this frame means this again while the keypads' addresses stay the
        # same. Full, the frames kept stay (those seen first repeat: commands, key messages;
        # a heartbeat's counter never does), and are only replaced by themselves
        if len(addresses) == before and (len(known_frames) < _J1939_KEPT or known is not None):
            known_frames[frame] = self._served = [parts, None, before, None]
        return _new_tuple(Event, (time, frame, Kind.J1939, *parts))

    def _unknown(self, frame: Frame, time: float) -> Event:
        node = frame.can_id & 0x7F
        event = Event(time, frame, Kind.FRAME, f"frame {frame.can_id:03X}h", node or None,
                      self._who(node))
        self._keep_raw(event)  # until the node's model is learned (_forget_routes)
        return event

    # -- PDOs -------------------------------------------------------------------------------------

    def _pdo_routes(self, layout: PdoLayout, node: int, description: DeviceDescription
                    ) -> tuple[Callable[[Frame, float], Event], _Writer | None,
                               Callable[[bytes], str]]:
        """The PDO's three renderings of one describer (decode/describers.py): its Event, its
        JSON line after the time written from the data (:meth:`json_rest`: the same text as
        the Event's ``to_json``, without the Event and the dicts in between), and its
        one-line text (:meth:`text`, ``str(event)``). No JSON writer (None) where a name of
        the layout would need JSON escapes (none does: the Event writes them)."""
        describe, describe_json, describe_text = pdo_renderings(layout, description, node,
                                                                self._keys)
        device, name, min_length = description.kind, layout.name, layout.min_length
        too_short = f"{layout.label}: too short"

        def route(frame: Frame, time: float) -> Event:
            data = frame.data
            if len(data) < min_length:
                return Event(time, frame, Kind.FRAME, too_short, node, device)
            text, fields = describe(data)
            return Event(time, frame, Kind.PDO, text, node, device, {"pdo": name, **fields})

        who = f"{device} {node:02X}h: "
        short_text = who + too_short

        def text_writer(data: bytes) -> str:
            if len(data) < min_length:
                return short_text
            return who + describe_text(data)

        names = [device, name, too_short, *(colour.label for colour in BacklightColour)]
        for signal in layout.signals:
            names += [signal.name, signal.label, signal.item or "", signal.unit]
        if not layout.signals or any(_encode_text(text) != f'"{text}"' for text in names):
            return route, None, text_writer
        head = f',"id":{layout.cob_id(node)},"extended":false,"data":"'
        named = f'"node":{node},"device":"{device}","text":"{who}'
        middle = f'","kind":"pdo",{named}'
        short = f'","kind":"frame",{named}{too_short}"}}'
        after_text = f'","pdo":"{name}",'
        pure = keyed_signal(layout) is None
        written: dict[bytes, str] = {}  # a pure PDO's lines by data: periodic ones repeat

        def writer(data: bytes) -> str:
            if pure:
                rest = written.get(data)
                if rest is not None:
                    return rest
            if len(data) < min_length:
                return f"{head}{data.hex()}{short}"
            text, members = describe_json(data)
            rest = f"{head}{data.hex()}{middle}{text}{after_text}{members}}}"
            if pure:
                if len(written) >= _WRITTEN_KEPT:
                    written.clear()
                written[data] = rest
            return rest

        return route, writer, text_writer

    def _heartbeat_writer(self, can_id: int) -> _Writer:
        """A node's heartbeat lines after the time by data (a node sends a few states), made
        by the Event route once; a boot-up forgets the node's keys each time (PKP §10)."""
        node = can_id & 0x7F
        written: dict[bytes, str] = {}

        def writer(data: bytes) -> str:
            rest = written.get(data)
            if rest is None:
                event = self._heartbeat(_new_tuple(Frame, (can_id, data, False)), 1.0)
                rest = _encode(event.to_json())[len(_TIME_FIELD + "1.0"):]
                if len(written) >= _WRITTEN_KEPT:
                    written.clear()
                written[data] = rest
            elif data[:1] == _BOOT_UP:
                self._keys.pop(node, None)
            return rest

        return writer

    # -- SDO --------------------------------------------------------------------------------------

    def _sdo_seen(self, frame: Frame, time: float) -> tuple[Kind, list[Any]] | None:
        """An SDO frame that makes a kept event again (Decoder._keep): the transfer state it
        moves is moved, and its kind and kept entry returned; None for any other frame."""
        can_id = frame[0]
        node = can_id & 0x7F
        if can_id & 0x780 == SDO_RX:  # an upload request seen before: the same object
            kept = self._kept.get(frame)
            if kept is not None:
                index, sub, entry = kept[2]
                self._transfers[node] = _Transfer(index, sub, entry, False, time)
                return Kind.SDO_READ, kept
        else:  # an expedited upload response seen before to a read of the same object
            transfer = self._transfers.get(node)
            if transfer is not None and not transfer.writing:
                kept = self._kept.get((frame, transfer.index, transfer.subindex))
                if kept is not None and 0 <= time - transfer.last <= TRANSFER_IDLE_S:
                    del self._transfers[node]
                    return Kind.SDO_VALUE, kept
        return None

    def _sdo(self, frame: Frame, time: float) -> Event:
        seen = self._sdo_seen(frame, time)
        if seen is not None:
            kind, kept = seen
            self._served = kept
            return _new_tuple(Event, (time, frame, kind, *kept[0]))
        return self._sdo_new(frame, time)

    def _sdo_new(self, frame: Frame, time: float) -> Event:
        """An SDO frame that is not a kept event's (Decoder._sdo_seen)."""
        node = frame.can_id & 0x7F
        data = frame.data
        device = self.devices.get(node)
        kind = device.kind if device is not None else None
        if frame.can_id & 0x780 == SDO_RX:
            if len(data) < 8:  # read as the devices do: padded with zeros (errata P10)
                data = data + bytes(8 - len(data))
            return self._sdo_request(frame, data, time, node, device)
        if len(data) < 8:
            return Event(time, frame, Kind.FRAME, "SDO reply shorter than 8 bytes", node, kind)
        self._hear(node)  # an SDO server answered there
        return self._sdo_reply(frame, time, node, device)

    def _entry(self, device: DeviceDescription | None, index: int, sub: int) -> ObjectEntry | None:
        return device.table.get(index, sub) if device is not None else None

    @staticmethod
    def _name(index: int, sub: int, entry: ObjectEntry | None) -> str:
        return f"{index:04X}h/{sub:02X}" + (f" {entry.label}" if entry else "")

    def _sdo_request(self, frame: Frame, data: bytes, time: float, node: int,
                     device: DeviceDescription | None) -> Event:
        request = parse_sdo(data[:8])
        ccs = request.specifier
        kind = device.kind if device is not None else None
        if ccs in _INITIATE_REQUESTS:  # CiA 301 §7.2.4.3.3, §7.2.4.3.6, §7.2.4.3.17
            index, sub = request.object_index, request.subindex
            entry = self._entry(device, index, sub)
            name = self._name(index, sub, entry)
            fields = {"index": index, "subindex": sub, "object": entry.name if entry else None}
            if ccs == CCS_INITIATE_UPLOAD:
                self._transfers[node] = _Transfer(index, sub, entry, False, time)
                event = Event(time, frame, Kind.SDO_READ, f"SDO read {name}", node, kind, fields)
                self._keep(frame, event, (index, sub, entry))
                return event
            if ccs == CCS_ABORT:
                self._transfers.pop(node, None)
                code = request.word
                return Event(time, frame, Kind.SDO_ABORT, f"SDO abort {name} by the client: "
                             f"{describe_abort(code)}", node, kind, {**fields, "code": code})
            self._transfers[node] = _Transfer(index, sub, entry, True, time)
            if not request.expedited:
                return Event(time, frame, Kind.SDO_WRITE, f"SDO segmented write {name}", node,
                             kind, fields)
            raw = request.expedited_data
            value = entry.decode(raw) if entry is not None else int.from_bytes(raw, "little")
            if index == 0x20FF and sub == 1 and value == 1:
                text = "switch to J1939 (PKP §44)"
                return Event(time, frame, Kind.J1939, text, node, kind, {**fields, "value": 1})
            return Event(time, frame, Kind.SDO_WRITE, f"SDO write {name} = {_show(value)}",
                         node, kind, {**fields, "value": value})
        if ccs == CCS_UPLOAD_SEGMENT:  # CiA 301 §7.2.4.3.7
            return Event(time, frame, Kind.SDO_SEGMENT, "SDO read, next segment", node, kind)
        if ccs == CCS_DOWNLOAD_SEGMENT:  # CiA 301 §7.2.4.3.4
            transfer = self._live_transfer(node, time)
            if transfer is not None and not self._grow(node, transfer, len(request.segment_data)):
                return Event(time, frame, Kind.SDO_SEGMENT, f"SDO write segment: over "
                             f"{TRANSFER_MAX_BYTES} bytes, no longer followed", node, kind)
            return Event(time, frame, Kind.SDO_SEGMENT, "SDO write segment", node, kind)
        return Event(time, frame, Kind.FRAME, f"SDO request {request.command:02X}h", node, kind)

    def _sdo_reply(self, frame: Frame, time: float, node: int,
                   device: DeviceDescription | None) -> Event:
        reply = parse_sdo(frame.data[:8])
        command, scs = reply.command, reply.specifier
        kind = device.kind if device is not None else None
        transfer = self._live_transfer(node, time)
        if scs == SCS_ABORT:  # CiA 301 §7.2.4.3.17
            self._transfers.pop(node, None)
            index, sub, code = reply.object_index, reply.subindex, reply.word
            name = self._name(index, sub, self._entry(device, index, sub))
            return Event(time, frame, Kind.SDO_ABORT,
                         f"SDO abort {name}: {code:08X}h {describe_abort(code)}", node, kind,
                         {"index": index, "subindex": sub, "code": code,
                          "meaning": describe_abort(code)})
        if transfer is None:
            return Event(time, frame, Kind.FRAME, f"SDO reply {command:02X}h", node, kind)
        name = self._name(transfer.index, transfer.subindex, transfer.entry)
        fields: dict[str, Any] = {"index": transfer.index, "subindex": transfer.subindex,
                                  "object": transfer.entry.name if transfer.entry else None}
        ours = reply.object_index == transfer.index and reply.subindex == transfer.subindex
        if transfer.writing and command in QUIRK_ACKNOWLEDGES and ours:
            self._transfers.pop(node, None)  # CiA 301 §7.2.4.3.3; errata K3: 43h too
            return Event(time, frame, Kind.SDO_WRITTEN, f"SDO write {name} done", node, kind,
                         fields)
        upload = transfer.upload
        if upload is None or not (command in _UPLOAD_SIZES or command == SEGMENTED_UPLOAD_RESPONSE
                                  or scs == SCS_UPLOAD_SEGMENT):
            pass  # not a reply a read is answered with (CiA 301 §7.2.4.3.6, §7.2.4.3.7)
        elif scs == SCS_UPLOAD_SEGMENT and \
                upload.received + len(reply.segment_data) > TRANSFER_MAX_BYTES:
            self._transfers.pop(node, None)
            return Event(time, frame, Kind.SDO_SEGMENT, f"SDO read {name}: over "
                         f"{TRANSFER_MAX_BYTES} bytes, no longer followed", node, kind, fields)
        else:
            try:
                upload.on_reply(reply.raw)
            except SdoError:  # for another object, or a toggle out of step: not this read's
                self._transfers.pop(node, None)
                return Event(time, frame, Kind.FRAME, f"SDO reply {command:02X}h", node, kind)
            if upload.done:
                self._transfers.pop(node, None)
                event = self._value(frame, time, node, kind, transfer, upload.value, name,
                                    fields)
                if scs == SCS_INITIATE_UPLOAD and transfer.index not in _IDENTITY:
                    self._keep((frame, transfer.index, transfer.subindex), event, None)
                return event  # an expedited one is kept: no model is learned from it
            if scs == SCS_INITIATE_UPLOAD:
                size = upload.size
                return Event(time, frame, Kind.SDO_SEGMENT,
                             f"SDO read {name}: {size} bytes follow", node, kind,
                             {**fields, "size": size})
            return Event(time, frame, Kind.SDO_SEGMENT,
                         f"SDO read {name}: segment {reply.raw[1:8]!r}", node, kind, fields)
        if scs == SCS_DOWNLOAD_SEGMENT and transfer.writing:  # CiA 301 §7.2.4.3.4
            return Event(time, frame, Kind.SDO_SEGMENT, "SDO write segment acknowledged", node,
                         kind, fields)
        return Event(time, frame, Kind.FRAME, f"SDO reply {command:02X}h", node, kind)

    def _keep(self, key: object, event: Event, transfer: tuple[int, int, ObjectEntry | None] | None
              ) -> None:
        """Remember an SDO event that the same frame (in the same transfer) makes again."""
        kept = self._kept
        if len(kept) >= _SDO_KEPT:
            kept.clear()
        kept[key] = self._served = [event[3:], None, transfer, None]

    def _live_transfer(self, node: int, time: float) -> _Transfer | None:
        """The node's transfer in progress, unless it went silent (TRANSFER_IDLE_S)."""
        transfer = self._transfers.get(node)
        if transfer is not None:
            if not 0 <= time - transfer.last <= TRANSFER_IDLE_S:
                del self._transfers[node]
                return None
            transfer.last = time
        return transfer

    def _grow(self, node: int, transfer: _Transfer, size: int) -> bool:
        """Count a write segment; False (and the transfer dropped) past TRANSFER_MAX_BYTES."""
        if transfer.written + size > TRANSFER_MAX_BYTES:
            self._transfers.pop(node, None)
            return False
        transfer.written += size
        return True

    def _value(self, frame: Frame, time: float, node: int, kind: str | None,
               transfer: _Transfer, raw: bytes, name: str, fields: dict[str, Any]) -> Event:
        entry = transfer.entry
        value: int | str
        if entry is not None:
            value = entry.decode(raw)
        elif transfer.index in (0x1008, 0x1009, 0x100A, 0x100B, 0x2200):
            value = raw.decode("ascii", "replace")
        else:
            value = int.from_bytes(raw, "little")
        if self._learn(node, transfer.index, value):  # now the object has a name
            entry = self._entry(self.devices.get(node), transfer.index, transfer.subindex)
            name = self._name(transfer.index, transfer.subindex, entry)
        kind = self._who(node)
        return Event(time, frame, Kind.SDO_VALUE, f"SDO value {name} = {_show(value)}", node,
                     kind, {**fields, "value": value})

    def _learn_sender(self, can_id: int, node: int) -> None:
        """Name an unknown (or guessed) node's model from a PDO only that model sends
        (sole_senders): as certain as 100Bh, so later identity does not change it. Routed
        once per identifier: the frames before this one keep their meaning. A node nobody
        assumed is named only once it is heard as a CANopen node (Decoder._hear, before or
        after): other ECUs' 11-bit frames use these identifiers too, and one of
        them must not make a keypad up."""
        sender = sole_senders().get(can_id - node)
        if sender is None or not self.learn:
            return
        known = self.devices.get(node)
        if known is not None and node not in self._guessed:
            return  # named by the caller, or by 100Bh
        if known is None and node not in self._heard:  # maybe another ECU's 11-bit frame
            self._unconfirmed.setdefault(node, sender)
            return
        self._guessed.discard(node)
        if known is not None and known.model == sender.model:
            return
        self.devices[node] = sender
        self._forget_routes(node)

    def _learn(self, node: int, index: int, value: int | str) -> bool:
        """Name an unknown node's model from its identity; True when it was learned."""
        if not self.learn:
            return False
        known = self.devices.get(node)
        if known is not None and node not in self._guessed:
            return False
        device = None
        if index == 0x1000 and isinstance(value, int) and known is None:
            device = identify(device_type=value)  # the first model with this 1000h
            self._guessed.add(node)
        elif index == 0x100B and isinstance(value, str):
            device = identify(model_id=value)  # 100Bh names the model (MT M59)
            self._guessed.discard(node)
            if known is not None and (device is None or device.model == known.model):
                return False
        if device is None:
            return False
        self.devices[node] = device
        self._forget_routes(node)
        return True


#: SocketCAN error classes, the bits of an error frame's identifier (linux/can/error.h)
ERROR_CLASSES = (
    (0x001, "TX timeout"), (0x002, "lost arbitration"), (0x004, "controller problem"),
    (0x008, "protocol violation"), (0x010, "transceiver status"), (0x020, "no ACK"),
    (0x040, "bus-off"), (0x080, "bus error"), (0x100, "controller restarted"),
)


def error_event(time: float, error_class: int, data: bytes) -> Event:
    """An error frame; ``error_class`` is the SocketCAN class bits (0 when the log has none)."""
    names = [name for bit, name in ERROR_CLASSES if error_class & bit]
    frame = Frame.trusted(error_class & 0x1FFFFFFF, bytes(data[:8]), True)
    return Event(time, frame, Kind.ERROR, f"error frame: {', '.join(names) or 'unspecified'}",
                 fields={"errors": names})


def _show(value: int | str) -> str:
    return repr(value) if isinstance(value, str) else f"{value:X}h"


__all__ = ["ERROR_CLASSES", "TRANSFER_IDLE_S", "TRANSFER_MAX_BYTES", "Decoder", "Event", "Kind",
           "error_event", "listing", "mask_listing", "numbers"]
