"""A log's frames decoded into the rows of a row group, a block of columns at a time.

The decoder runs once per frame (its events carry state: keys held, SDO transfers, learned
models), and so does :class:`~blinkcan.fleet.rows.EventRows` for the events that say more than
their kind; everything else is gathered per column (a list each, extended by the block's) and
becomes Arrow arrays once per row group (``writer.py``). Most frames of a fleet's log are other
ECUs' (undecoded, one row, the decoder's lookup): for them the loop appends the node, the
model, one shared row detail and the text, nothing more.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from blinkcan.decode.decoder import Decoder, Event
from blinkcan.fleet.rows import SIMPLE_ROWS, Detail, EventRows
from blinkcan.formats.columns import FrameColumns
from blinkcan.formats.logs import describe_frame, frame_kind
from blinkcan.formats.unreadable import UnreadableLine
from blinkcan.protocol.frame import Frame

if TYPE_CHECKING:
    import can

_new_tuple = tuple.__new__  # Frame.trusted without the call: the readers checked the frames
#: texts of undecoded frames kept (then they start over): a log has a few hundred identifiers
_TEXTS_KEPT = 4096


@dataclass
class Segment:
    """The rows of one row group in the making: per frame its log columns (time, channel,
    identifier, flag, data) and what its event says (node, model, text, one detail per row)."""

    times: list[float] = field(default_factory=list)
    channels: list[str | None] = field(default_factory=list)
    ids: list[int | None] = field(default_factory=list)  # None: an unreadable line
    extended: list[bool | None] = field(default_factory=list)
    data: list[bytes | None] = field(default_factory=list)
    nodes: list[int | None] = field(default_factory=list)
    models: list[str | None] = field(default_factory=list)
    texts: list[str] = field(default_factory=list)
    details: list[list[Detail]] = field(default_factory=list)
    #: rows so far (a frame is one row or more)
    rows: int = 0

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
        self.details.append([Detail("unreadable", value=line.number)])
        self.texts.append(line.text)
        self.rows += 1

    def clear(self) -> None:
        for column in (self.times, self.channels, self.ids, self.extended, self.data,
                       self.nodes, self.models, self.texts, self.details):
            column.clear()
        self.rows = 0


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

    def decode(self, block: FrameColumns, start: int, segment: Segment, limit: int) -> int:
        """Decode the block's frames from ``start`` into ``segment`` until it holds ``limit``
        rows or more; returns the position after the last frame decoded."""
        if block.others:
            return self._decode_mixed(block, start, segment, limit)
        return self._decode_run(block, start, len(block), segment, limit)

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
            segment.details.append(details)
            segment.texts.append(str(event))
            segment.rows += len(details)
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

    def _decode_data(self, times: list[float], ids: list[int], data: list[bytes],
                     extended: list[bool], segment: Segment, limit: int) -> int:
        """The classic data frames of a block: returns how many were decoded."""
        decode, rows = self._decoder.decode, self._rows.rows
        devices = self._decoder.devices
        add_node, add_model = segment.nodes.append, segment.models.append
        add_text, add_details = segment.texts.append, segment.details.append
        simple_rows = SIMPLE_ROWS
        new, frame_type = _new_tuple, Frame
        texts = self._texts
        if len(texts) > _TEXTS_KEPT:
            texts.clear()
        total = segment.rows
        count = 0
        for timestamp, can_id, payload, flag in zip(times, ids, data, extended, strict=True):
            event = decode(new(frame_type, (can_id, payload, flag)), timestamp)
            count += 1
            simple = simple_rows.get(event.kind)
            if simple is not None:  # most of a fleet's log: other ECUs' frames
                node = event.node_id
                device = devices.get(node)  # type: ignore[arg-type]  # None: no device
                add_node(node)
                add_model(None if device is None else device.model)
                add_details(simple)
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
                add_details(details)
                total += len(details)
                add_text(str(event))
            if total >= limit:
                break
        segment.rows = total
        return count
