"""A log's frames a block at a time, as columns: what a columnar consumer (the fleet's Parquet
writer) reads without an object per frame.

Classic data frames are plain values in the lists; a frame that is not one (remote, error,
CAN FD) keeps python-can's message in ``others`` at its position, its time and channel in the
lists beside the others' and its identifier, flag and data as the message has them. A line
that is no frame (formats/unreadable.py) is in ``others`` too, in its place: its time (NaN
where it has none) in ``times``, nothing in the other lists but a placeholder.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # python-can loads where a log needs it: a candump log reads without it
    import can
    import numpy as np
    import numpy.typing as npt
    import pyarrow as pa

    from blinkcan.formats.unreadable import UnreadableLine


@dataclass
class FrameColumns:
    """A block of frames, in the log's order: row ``n`` is ``times[n]``, ``ids[n]``, ..."""

    times: list[float] = field(default_factory=list)
    #: the log's channel of each frame (None where the format has none)
    channels: list[str | None] = field(default_factory=list)
    ids: list[int] = field(default_factory=list)
    extended: list[bool] = field(default_factory=list)
    data: list[bytes] = field(default_factory=list)
    #: the rows that are not classic data frames: position -> python-can's message, or the
    #: line that is no frame
    others: dict[int, can.Message | UnreadableLine] = field(default_factory=dict)

    def __len__(self) -> int:
        return len(self.times)

    def add_frame(self, time: float, channel: str | None, can_id: int, extended: bool,
                  data: bytes) -> None:
        """A classic data frame, in the next row."""
        self.times.append(time)
        self.channels.append(channel)
        self.ids.append(can_id)
        self.extended.append(extended)
        self.data.append(data)

    def add_other(self, message: can.Message, channel: str | None) -> None:
        """A frame that is not a classic data frame, as python-can read it."""
        self.others[len(self.times)] = message
        self.add_frame(message.timestamp, channel, message.arbitration_id,
                       message.is_extended_id, bytes(message.data))


    def add_unreadable(self, line: UnreadableLine) -> None:
        """A line that is no frame, in its place (:mod:`blinkcan.formats.unreadable`)."""
        self.others[len(self.times)] = line
        self.times.append(math.nan if line.time is None else line.time)
        self.channels.append(None)
        self.ids.append(0)
        self.extended.append(False)
        self.data.append(b"")



class ArrowColumns(FrameColumns):
    """A block of classic data frames only, read whole by Arrow (formats/candump_columns.py):
    its frames are in Arrow arrays, ``others`` is empty; the lists are made from the arrays
    where something reads them (the fleet's writer takes the arrays). ``identifiers`` are
    the block's distinct identifier texts as (id, extended), ``index`` each frame's place
    in them (a log has a few hundred identifiers)."""

    def __init__(self, times: pa.DoubleArray, channels: pa.StringArray, ids: pa.Int32Array,
                 extended: pa.BooleanArray, data: pa.BinaryArray,
                 identifiers: list[tuple[int, bool]], index: npt.NDArray[np.int32]) -> None:
        # not FrameColumns.__init__: its lists are made on first use (__getattr__)
        self.others = {}
        self.arrow_times, self.arrow_channels, self.arrow_ids = times, channels, ids
        self.arrow_extended, self.arrow_data = extended, data
        self.identifiers, self.index = identifiers, index

    def __getattr__(self, name: str) -> list[object]:
        """A list (``times``, ``channels``, ``ids``, ``extended``, ``data``) from its array."""
        array = self.__dict__.get(f"arrow_{name}") if name in _LISTS else None
        if array is None:
            raise AttributeError(name)
        values: list[object] = array.to_pylist()
        setattr(self, name, values)
        return values

    def __len__(self) -> int:
        return len(self.arrow_times)


_LISTS = frozenset({"times", "channels", "ids", "extended", "data"})
