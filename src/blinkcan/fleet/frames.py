"""A log's frames decoded into the rows of a row group, a block of columns at a time.

The decoder runs once per frame (its events carry state: keys held, SDO transfers, learned
models), and so does :class:`~blinkcan.fleet.rows.EventRows` for the events that say more than
their kind; everything else is gathered per column (a list each, extended by the block's) and
becomes Arrow arrays once per row group (``writer.py``). A row's detail is kept as a number:
each distinct detail of the row group is in a table once, so the lists hold plain numbers,
strings and bytes and no object per row (nothing for the garbage collector to go through,
and one Arrow conversion per distinct detail). Most frames of a fleet's log are other ECUs'
(undecoded, one row, the decoder's lookup): for them the loop appends the node, the model,
one shared detail's number and the text, nothing more. The devices' own frames go to the
decoder, but for those whose meaning is their bytes alone: a PDO's frame (LED pictures,
outputs, faults, brightness: most of the devices' frames) is described by the decoder's
describer and rowed from its bytes (:class:`PdoRoute`, EventRows.follower), with no Event and
no fields read back (those that follow no state kept by their bytes); a heartbeat is kept by
its bytes; a key state by its keys and the keys held before it (Decoder.key_signal: the
decoder's keys moved, its text the decoder's, its rows from the masks); the rows of an event
the decoder keeps (an SDO read seen before, a J1939 keypad frame) by that entry, with no
decode (Decoder.kept_event), a J1939 one by its bytes while the keypads' addresses stay.
``FrameDecoder.fast = False`` makes every device frame's rows of its event (the reference of
tests/fleet/test_fast_rows.py).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np
import pyarrow as pa

from blinkcan.decode.decoder import Decoder, Event, Kind
from blinkcan.decode.describers import Describe, DescribeText, keyed_signal, pdo_renderings
from blinkcan.devices.model import DeviceDescription
from blinkcan.fleet.rows import SIMPLE_ROWS, Detail, EventRows, Follower, key_rows
from blinkcan.formats.columns import ArrowColumns, FrameColumns
from blinkcan.formats.logs import describe_frame, frame_kind
from blinkcan.formats.unreadable import UnreadableLine
from blinkcan.protocol.cob import HEARTBEAT
from blinkcan.protocol.frame import Frame

if TYPE_CHECKING:
    import can

_new_tuple = tuple.__new__  # Frame.trusted without the call: the readers checked the frames
#: texts of undecoded frames kept (then they start over): a log has a few hundred identifiers
_TEXTS_KEPT = 4096
#: entries of the fleet's own caches of rows (key states, J1939 frames by bytes, frames too short
#: for their PDO, a stateless PDO's by bytes) kept (then they start over)
_ROWS_KEPT = 4096
#: the event kinds whose rows read or change what EventRows follows (never kept)
_FOLLOWING = frozenset({Kind.PDO, Kind.BOOT_UP})
#: a PDO identifier's follower not made yet (FrameDecoder._followers)
_FOLLOWED: Any = object()
#: the Arrow types of a frame's columns: time (seconds), channel, identifier, flag, data
_FRAME_TYPES = (pa.float64(), pa.string(), pa.int32(), pa.bool_(), pa.binary())
FrameArrays = tuple[pa.Array, pa.Array, pa.Array, pa.Array, pa.Array]
#: what a device frame made: node, model, text, a detail per row
KeptRows = tuple[int | None, str | None, str, list[Detail]]


class PdoRoute(NamedTuple):
    """A PDO identifier whose frames mean what their bytes say (no state of the decoder read
    or changed: Decoder.repeat_state is empty), made once per identifier: a frame of its
    full length is described by the decoder's describer and rowed by its follower, with
    no Event (a frame shorter goes to the decoder)."""

    node: int
    model: str
    #: the start of its events' text (Event.__str__: the device and the node)
    who: str
    length: int
    #: frames shorter than this mean only that (the decoder's "too short", kept the first
    #: time: FrameDecoder._pure)
    shortest: int
    #: the decoder's describers of the PDO (decode/describers.py pdo_renderings): its text
    #: and fields, and its text alone (for the frames a follower rows)
    describe: Describe
    text: DescribeText
    #: its rows from the bytes (EventRows.follower), or None: its one EventRows.pdo_detail
    follow: Follower | None
    pdo: str
    #: the text and rows of frames rowed without a follower (they follow no state), by their
    #: bytes: periodic ones repeat (brightness levels)
    rowed: dict[bytes, tuple[str, list[Detail]]]


@dataclass
class Segment:
    """The rows of one row group in the making: per frame its log columns (time, channel,
    identifier, flag, data) and what its event says (node, model, text); per row the number
    of its detail in ``details`` (each distinct detail once). A frame is one row unless
    ``multiple`` says otherwise."""

    times: list[float] = field(default_factory=list)
    channels: list[str | None] = field(default_factory=list)
    ids: list[int | None] = field(default_factory=list)  # None: an unreadable line
    extended: list[bool | None] = field(default_factory=list)
    data: list[bytes | None] = field(default_factory=list)
    nodes: list[int | None] = field(default_factory=list)
    models: list[str | None] = field(default_factory=list)
    texts: list[str] = field(default_factory=list)
    #: per row: its detail's number (its place in ``details``)
    codes: list[int] = field(default_factory=list)
    #: the distinct details of the rows, in the order they came
    details: list[Detail] = field(default_factory=list)
    #: the frames of more than one row: their positions, and their rows' counts
    multiple: list[int] = field(default_factory=list)
    counts: list[int] = field(default_factory=list)
    #: the number of each detail in ``details``
    numbers: dict[Detail, int] = field(default_factory=dict)
    #: the number of the one detail of each kind of event that has nothing else
    simple: dict[Kind, int] = field(default_factory=dict)
    #: the frame columns of the frames before those in the lists, as Arrow arrays (a block
    #: read by Arrow is kept as it is; the lists before it become arrays then)
    chunks: list[FrameArrays] = field(default_factory=list)

    def __post_init__(self) -> None:
        self.simple.update((kind, self.number(rows[0])) for kind, rows in SIMPLE_ROWS.items())

    @property
    def rows(self) -> int:
        """Rows so far (a frame is one row or more)."""
        return len(self.codes)

    def __len__(self) -> int:
        return len(self.texts)

    def add_unreadable(self, line: UnreadableLine, time: float) -> None:
        """A line of the log that is no frame: an ``unreadable`` row with its raw text, its
        line number as the value, and no identifier or data (issue 23)."""
        self.times.append(time)
        self.channels.append(None)
        self.ids.append(None)
        self.extended.append(None)
        self.data.append(None)
        self.nodes.append(None)
        self.models.append(None)
        self.texts.append(line.text)
        self.add_rows([Detail("unreadable", value=line.number)])

    def number(self, detail: Detail) -> int:
        """The number of a detail in ``details`` (added if new)."""
        number = self.numbers.get(detail)
        if number is None:
            number = self.numbers[detail] = len(self.details)
            self.details.append(detail)
        return number

    def add_rows(self, details: list[Detail]) -> None:
        """The rows of the frame added last."""
        number, add = self.number, self.codes.append
        if len(details) == 1:
            add(number(details[0]))
            return
        self.multiple.append(len(self.texts) - 1)
        self.counts.append(len(details))
        for detail in details:
            add(number(detail))

    def frame_rows(self) -> list[int]:
        """The count of rows of each frame."""
        counts = [1] * len(self.texts)
        for position, count in zip(self.multiple, self.counts, strict=True):
            counts[position] = count
        return counts

    def add_arrow(self, block: ArrowColumns, start: int, end: int) -> None:
        """The frame columns of the block's frames ``start:end`` (their rows are added
        apart)."""
        self._seal()
        size = end - start
        self.chunks.append((block.arrow_times.slice(start, size),
                            block.arrow_channels.slice(start, size),
                            block.arrow_ids.slice(start, size),
                            block.arrow_extended.slice(start, size),
                            block.arrow_data.slice(start, size)))

    def _seal(self) -> None:
        """The frame columns in the lists as Arrow arrays, after the chunks before them."""
        if self.times:
            columns = (self.times, self.channels, self.ids, self.extended, self.data)
            self.chunks.append(tuple(
                pa.array(column, kind) for column, kind in zip(columns, _FRAME_TYPES,
                                                               strict=True)))
            for column in columns:
                column.clear()

    def frame_arrays(self) -> FrameArrays:
        """Every frame's time (seconds), channel, identifier, flag and data, in order."""
        self._seal()
        if len(self.chunks) == 1:
            return self.chunks[0]
        if not self.chunks:
            return tuple(pa.array([], kind) for kind in _FRAME_TYPES)
        return tuple(pa.concat_arrays([chunk[n] for chunk in self.chunks])
                     for n in range(len(_FRAME_TYPES)))

    def clear(self) -> None:
        for column in (self.times, self.channels, self.ids, self.extended, self.data,
                       self.nodes, self.models, self.texts, self.codes, self.details,
                       self.multiple, self.counts, self.chunks):
            column.clear()
        self.numbers.clear()
        self.simple.clear()
        self.__post_init__()


def other_event(decoder: Decoder, message: can.Message) -> Event:
    """A remote, error or CAN FD frame as ``blinkcan decode`` shows it."""
    return decoder.decode_other(frame_kind(message), message.timestamp, message.arbitration_id,
                                message.is_extended_id, message.dlc, bytes(message.data),
                                describe_frame(message))


class FrameDecoder:
    """Decodes the frames of one log, in order, into segments."""

    def __init__(self, decoder: Decoder) -> None:
        self._decoder = decoder
        self._rows = EventRows(decoder)
        #: an undecoded frame's text (str of its event) by the decoder's: (node, device, text)
        self._texts: dict[str, tuple[int | None, str | None, str]] = {}
        #: per 11-bit PDO identifier decoded, its route (None: its frames go to the decoder),
        #: for the devices' models it was made with
        self._pdo_routes: dict[int, PdoRoute | None] = {}
        #: rows of 11-bit frames whose event depends on their identifier and bytes alone and
        #: changes nothing (a heartbeat's; a frame too short for its PDO, by its identifier
        #: alone), by the identifier and bytes, for the devices' models they were made with
        self._pure: dict[object, KeptRows] = {}
        #: key-state PDO identifiers (their meaning depends on the keys held before: PKP §10):
        #: the decoder's (node, shift, mask) of their keys, and the shortest frame that has them
        self._keyed: dict[int, tuple[int, int, int, int]] = {}
        #: what a J1939 keypad frame the decoder keeps made (Decoder.kept_event), by its
        #: identifier and bytes, with the count of keypad addresses it was made with (its
        #: meaning depends on them alone: Decoder.repeat_state)
        self._j1939_rows: dict[tuple[int, bytes], tuple[int, KeptRows]] = {}
        #: what a key-state frame that has its keys made, by its identifier, its keys and the
        #: node's keys held before it (all its event depends on: Decoder.repeat_state; its
        #: tick is in no row), for the devices' models they were made with
        self._keyed_rows: dict[tuple[int, int, int], KeptRows] = {}
        self._models: dict[int, DeviceDescription] = {}
        #: False: every device frame's rows made of its event (the tests' reference)
        self.fast = True

    def _pdo_route(self, event: Event) -> PdoRoute | None:
        """The route of a PDO event's identifier, just decoded, where its frames mean what
        their bytes say (Decoder.repeat_state is empty: not a key state) and its rows are
        made from them (EventRows.follows: a follower; or the one pdo_detail); None
        otherwise. Its layout is the one the decoder routes the identifier to (the first of
        the node's model's PDOs on it, decode/decoder.py Decoder._route)."""
        frame, node, rows = event.frame, event.node_id, self._rows
        device = self._decoder.devices.get(node) if node is not None else None
        if device is None or node is None or frame.extended:
            return None
        layout = next((p for p in device.pdos if p.cob_id(node) == frame.can_id), None)
        if layout is None or layout.name != event.fields.get("pdo"):
            return None
        keys = self._decoder.key_signal(frame.can_id)
        if keys is not None and keys[0] == node and keyed_signal(layout) is not None:
            self._keyed[frame.can_id] = (*keys, layout.min_length)  # rows by keys (decode)
        if self._decoder.repeat_state(frame.can_id, False, frame.data) != ():
            return None
        follow = rows.follower(node, layout)
        if follow is None and rows.follows(layout.name):
            return None  # its rows read the event's fields (a layout of other signals)
        describe, _, text = pdo_renderings(layout, device, node, {})
        return PdoRoute(node, device.model, f"{event.device or 'node'} {node:02X}h: ",
                        layout.length, layout.min_length, describe, text, follow, layout.name,
                        {})

    def _event_rows(self, event: Event, place: int, nodes: list[int | None],
                    models: list[str | None], texts: list[str | None]) -> list[Detail]:
        """A decoded device frame's node, model and text set at ``place``; its rows."""
        kind = event[2]
        details = SIMPLE_ROWS.get(kind)
        if details is not None:  # another ECU's frame, or one of no detail
            node = event[4]
            device = self._decoder.devices.get(node)  # type: ignore[arg-type]  # None: none
            nodes[place] = node
            models[place] = None if device is None else device.model
            seen = self._texts.get(event.text)  # str(event): device, node and text
            if seen is not None and seen[0] == node and seen[1] == event.device:
                texts[place] = seen[2]
            else:
                texts[place] = text = str(event)
                self._texts[event.text] = (node, event.device, text)
            frame = event.frame
            route = self._pdo_routes.get(frame.can_id) if not frame.extended else None
            if self.fast and route is not None and len(frame.data) < route.shortest:
                self._pure[frame.can_id] = (node, models[place], str(texts[place]), details)
            return details
        if self.fast:
            entry = self._decoder.kept_entry(event)
            if entry is not None and kind not in _FOLLOWING:
                nodes[place], models[place], texts[place], details = self._kept_made(
                    entry, event)
                return details
            frame = event.frame
            if kind is Kind.PDO and not frame.extended and frame.can_id not in self._pdo_routes:
                self._pdo_routes[frame.can_id] = self._pdo_route(event)  # the next: bytes
            if kind is Kind.HEARTBEAT:  # its bytes and the node's model: the same rows
                return self._pure_rows((frame.can_id, frame.data), event, place, nodes,
                                       models, texts)
        nodes[place], models[place], details = self._rows.rows(event)
        texts[place] = str(event)
        return details

    def _pure_rows(self, key: object, event: Event, place: int, nodes: list[int | None],
                   models: list[str | None], texts: list[str | None]) -> list[Detail]:
        """:meth:`_event_rows` of an event its frame's identifier and bytes alone make (no
        state read or changed), kept by ``key`` for the next such frame."""
        node, model, details = self._rows.rows(event)
        text = str(event)
        nodes[place], models[place], texts[place] = node, model, text
        self._pure[key] = (node, model, text, details)
        return details

    def _kept_made(self, entry: list[Any], event: Event) -> KeptRows:
        """What an event made from an entry the decoder keeps (Decoder.kept_entry: an SDO
        read or value seen before, a J1939 keypad frame's) makes: what was made of that entry
        before, kept in the entry's last item (as long as the decoder keeps it) with the
        devices' models it was made with (``_models``). Such rows read no state (EventRows
        follows PDOs and boot-ups only)."""
        memo = entry[-1]
        if memo is not None and memo[0] is self._models:
            made: KeptRows = memo[1]
            return made
        node, model, details = self._rows.rows(event)
        made = (node, model, str(event), details)
        entry[-1] = (self._models, made)
        return made

    def decode(self, block: FrameColumns, start: int, segment: Segment, limit: int) -> int:
        """Decode the block's frames from ``start`` into ``segment`` until it holds ``limit``
        rows or more; returns the position after the last frame decoded."""
        if type(block) is ArrowColumns:
            return self._decode_arrow(block, start, segment, limit)
        if block.others:
            return self._decode_mixed(block, start, segment, limit)
        return self._decode_run(block, start, len(block), segment, limit)

    def _decode_arrow(  # noqa: PLR0915 (one loop per device frame, inlined as below)
            self, block: ArrowColumns, start: int, segment: Segment, limit: int) -> int:
        """A block read by Arrow: the frames another ECU sent and the decoder has seen (most
        of a fleet's log; :meth:`Decoder.undecoded`: the decoder's state does not depend on
        them) are filled in per identifier, the others decoded one by one, in order, as
        :meth:`_decode_data` does. The devices' models, which a foreign frame's row names,
        are learned from the bus (identity): where a frame changes them, this stops after
        it, and the next call starts over from the state it left (so the rows are the
        frame-by-frame path's). Nothing is kept per frame but plain values in flat lists
        (objects that outlive a frame would wake the garbage collector)."""
        decoder = self._decoder
        decode, devices = decoder.decode, decoder.devices
        known = list(map(decoder.undecoded, *zip(*block.identifiers, strict=True)))
        foreign = np.fromiter((k is not None for k in known), np.bool_, len(known))
        index = block.index[start:]
        at = np.flatnonzero(~foreign[index])
        # every frame's row as a foreign frame's (by its identifier), then the others' set
        by_node = [None if k is None else k[1] for k in known]
        by_model = [None if device is None else device.model
                    for device in map(devices.get, by_node)]  # type: ignore[arg-type]  # None: no device
        by_text = [None if k is None else k[0] for k in known]
        nodes: list[int | None]
        models: list[str | None]
        texts: list[str | None]
        nodes, models, texts = (np.array(column, object)[index].tolist()  # (numpy: no call
                                for column in (by_node, by_model, by_text))  # per frame)
        codes = [segment.simple[Kind.FRAME]] * len(index)
        several: list[int] = []  # frames of more than one row: where, how many, their codes
        several_counts: list[int] = []
        several_codes: list[int] = []
        identifiers = block.identifiers
        idents = list(map(identifiers.__getitem__, index[at].tolist()))
        times = block.arrow_times.to_numpy()[at + start].tolist()
        payloads = block.arrow_data.take(pa.array(at + start, pa.int64())).to_pylist()
        snapshot = dict(devices)
        if self._models != snapshot:  # a model learned: what was made names the old ones
            self._pdo_routes.clear()
            self._pure.clear()
            self._keyed.clear()
            self._keyed_rows.clear()
            self._j1939_rows.clear()
            self._models = snapshot
        fast, pdo_routes, pdo_detail = self.fast, self._pdo_routes, self._rows.pdo_detail
        pure, heartbeat = self._pure, HEARTBEAT
        if len(pure) > _ROWS_KEPT:
            pure.clear()
        keyed, keyed_rows = self._keyed, self._keyed_rows
        if len(keyed_rows) > _ROWS_KEPT:
            keyed_rows.clear()
        j1939_rows, addresses = self._j1939_rows, decoder.j1939.addresses
        if len(j1939_rows) > _ROWS_KEPT:
            j1939_rows.clear()
        keys_held, hold_keys, frame_text = decoder.keys_held, decoder.hold_keys, decoder.text
        kept_event, kept_sdo, kept_made = decoder.kept_event, decoder.kept_sdo, self._kept_made
        kept_entry, models_now = decoder.kept_entry, self._models
        find_number, number = segment.numbers.get, segment.number
        event_texts = self._texts
        if len(event_texts) > _TEXTS_KEPT:
            event_texts.clear()
        new, frame_type = _new_tuple, Frame
        base = segment.rows
        rows_of_devices = 0  # the rows of the frames decoded
        end = len(index)  # frames from start
        for count, place in enumerate(at.tolist()):
            total = base + (place - count) + rows_of_devices  # rows before this frame
            if total >= limit:  # reached in the foreign frames before this one
                end = place - (total - limit)
                break
            can_id, flag = idents[count]
            payload = payloads[count]
            route = pdo_routes.get(can_id) if fast and not flag else None
            made = None
            if route is not None:
                if len(payload) >= route.length:  # no Event: its bytes
                    nodes[place], models[place] = route.node, route.model
                    follow = route.follow
                    if follow is not None:
                        texts[place] = route.who + route.text(payload)
                        details = follow(payload)
                    else:
                        rowed = route.rowed.get(payload)
                        if rowed is None:
                            if len(route.rowed) >= _ROWS_KEPT:
                                route.rowed.clear()
                            text, fields = route.describe(payload)
                            rowed = route.rowed[payload] = (
                                route.who + text, [pdo_detail(route.pdo, fields)])
                        texts[place], details = rowed
                elif len(payload) < route.shortest:
                    made = pure.get(can_id)
            elif not fast:
                pass
            elif not flag and can_id & 0x780 == heartbeat:
                made = pure.get((can_id, payload))
            elif not flag and can_id in keyed:  # a key state: by its keys and those before
                node, shift, mask, shortest = keyed[can_id]
                if len(payload) >= shortest:
                    keys = int.from_bytes(payload, "little") >> shift & mask
                    before = keys_held(node)
                    keyed_key = (can_id, keys, before)
                    made = keyed_rows.get(keyed_key)
                    if made is not None:
                        hold_keys(node, keys)
                    else:  # its text from the decoder (which holds its keys), its rows here
                        device = devices.get(node)
                        made = keyed_rows[keyed_key] = (
                            node, None if device is None else device.model,
                            frame_text(new(frame_type, (can_id, payload, False))),
                            key_rows(keys & ~before, before & ~keys, keys.bit_count()))
            elif not flag:  # an SDO event the decoder keeps: what was made of its entry
                seen = kept_sdo(can_id, payload, times[count])
                if seen is not None:
                    kind, entry = seen
                    memo = entry[3]  # (as _kept_made)
                    if memo is not None and memo[0] is models_now:
                        made = memo[1]
                    else:
                        made = kept_made(entry, new(Event, (times[count], new(frame_type, (
                            can_id, payload, False)), kind, *entry[0])))
            else:  # a J1939 keypad frame's event the decoder keeps: what it made before
                j1939_made = j1939_rows.get((can_id, payload))
                if j1939_made is not None and j1939_made[0] == len(addresses):
                    made = j1939_made[1]
                else:
                    event = kept_event(can_id, flag, payload, times[count])
                    kept = None if event is None else kept_entry(event)
                    if event is not None and kept is not None:
                        made = kept_made(kept, event)
                        j1939_rows[can_id, payload] = (len(addresses), made)
            decoded = False  # the decoder's devices change only where it decodes a frame
            if made is not None:
                nodes[place], models[place], texts[place], details = made
            elif route is None or len(payload) < route.length:
                decoded = True
                details = self._event_rows(
                    decode(new(frame_type, (can_id, payload, flag)), times[count]), place,
                    nodes, models, texts)
            added = 1
            if len(details) == 1:
                code = find_number(details[0])
                codes[place] = number(details[0]) if code is None else code
            else:
                added = len(details)
                several.append(place)
                several_counts.append(added)
                for detail in details:
                    code = find_number(detail)
                    several_codes.append(number(detail) if code is None else code)
            rows_of_devices += added
            if total + added >= limit or (decoded and devices != snapshot):
                end = place + 1  # full, or a model learned: the rest with the new state
                break
        else:
            total = base + (end - len(at)) + rows_of_devices
            if total >= limit:
                end -= total - limit
        frames = len(segment.texts)
        segment.nodes += nodes[:end]
        segment.models += models[:end]
        segment.texts += texts[:end]  # type: ignore[arg-type]  # every frame's is set
        if several:
            last = taken = 0
            for place, rows_count in zip(several, several_counts, strict=True):
                segment.codes += codes[last:place]
                segment.multiple.append(frames + place)
                segment.counts.append(rows_count)
                segment.codes += several_codes[taken:taken + rows_count]
                last, taken = place + 1, taken + rows_count
            segment.codes += codes[last:end]
        else:
            segment.codes += codes[:end]
        segment.add_arrow(block, start, start + end)
        return start + end

    def _decode_mixed(self, block: FrameColumns, start: int, segment: Segment,
                      limit: int) -> int:
        """A block with frames that are not classic data frames: the runs of data frames
        between them as usual, each other frame as its event says."""
        others = block.others
        position = start
        for other in sorted(p for p in others if p >= start):
            if position < other:
                position = self._decode_run(block, position, other, segment, limit)
                if segment.rows >= limit:
                    return position
            item = others[other]
            if isinstance(item, UnreadableLine):
                segment.add_unreadable(item, block.times[other])
                position = other + 1
                if segment.rows >= limit:
                    return position
                continue
            event = other_event(self._decoder, item)
            node, model, details = self._rows.rows(event)
            frame = event.frame
            segment.times.append(block.times[other])
            segment.channels.append(block.channels[other])
            segment.ids.append(frame.can_id)
            segment.extended.append(frame.extended)
            segment.data.append(frame.data)
            segment.nodes.append(node)
            segment.models.append(model)
            segment.texts.append(str(event))
            segment.add_rows(details)
            position = other + 1
            if segment.rows >= limit:
                return position
        return self._decode_run(block, position, len(block), segment, limit)

    def _decode_run(self, block: FrameColumns, start: int, end: int, segment: Segment,
                    limit: int) -> int:
        """The classic data frames ``start:end`` of a block, until ``limit`` rows."""
        times, ids, data, extended = block.times, block.ids, block.data, block.extended
        channels = block.channels
        if start or end < len(times):
            times, ids, data, extended = times[start:end], ids[start:end], data[start:end], \
                extended[start:end]
            channels = channels[start:end]
        count = self._decode_data(times, ids, data, extended, segment, limit)
        if count < len(times):
            times, ids, data, extended = times[:count], ids[:count], data[:count], \
                extended[:count]
            channels = channels[:count]
        segment.times += times
        segment.channels += channels
        segment.ids += ids
        segment.data += data
        segment.extended += extended
        return start + count

    def _decode_data(  # noqa: PLR0915 (one loop per frame, inlined: a call a frame costs)
            self, times: list[float], ids: list[int], data: list[bytes], extended: list[bool],
            segment: Segment, limit: int) -> int:
        """The classic data frames of a block: returns how many were decoded. Another ECU's
        frame seen before is a lookup (:meth:`Decoder.undecoded`): no Frame, no Event."""
        decode, rows = self._decoder.decode, self._rows.rows
        devices = self._decoder.devices
        add_node, add_model = segment.nodes.append, segment.models.append
        add_text, add_code = segment.texts.append, segment.codes.append
        add_rows, number, find_number = segment.add_rows, segment.number, segment.numbers.get
        simple = segment.simple
        new, frame_type = _new_tuple, Frame
        texts = self._texts
        if len(texts) > _TEXTS_KEPT:
            texts.clear()
        undecoded, frame_code = self._decoder.undecoded, simple[Kind.FRAME]
        total = segment.rows
        count = 0
        for timestamp, can_id, payload, flag in zip(times, ids, data, extended, strict=True):
            count += 1
            known_frame = undecoded(can_id, flag)
            if known_frame is not None:  # most of a fleet's log: another ECU's, seen before
                text, node, _ = known_frame
                device = devices.get(node)  # type: ignore[arg-type]  # None: no device
                add_node(node)
                add_model(None if device is None else device.model)
                add_code(frame_code)
                add_text(text)
                total += 1
                if total >= limit:
                    break
                continue
            event = decode(new(frame_type, (can_id, payload, flag)), timestamp)
            code = simple.get(event.kind)
            if code is not None:  # most of a fleet's log: other ECUs' frames
                node = event.node_id
                device = devices.get(node)  # type: ignore[arg-type]  # None: no device
                add_node(node)
                add_model(None if device is None else device.model)
                add_code(code)
                total += 1
                known = texts.get(event.text)  # str(event) is its device's, node's and text's
                if known is not None and known[0] == node and known[1] == event.device:
                    add_text(known[2])
                else:
                    text = str(event)
                    texts[event.text] = (node, event.device, text)
                    add_text(text)
            else:
                node, model, details = rows(event)
                add_node(node)
                add_model(model)
                add_text(str(event))
                if len(details) == 1:  # most events are one row
                    code = find_number(details[0])
                    add_code(number(details[0]) if code is None else code)
                    total += 1
                else:
                    add_rows(details)
                    total += len(details)
            if total >= limit:
                break
        return count
