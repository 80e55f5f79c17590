"""The ways a model's behaviour plugs into a twin: hooks of the shape ``(value, now) -> frames |
abort``, registered with :class:`~blinkcan.twin.base.CanopenTwin` (periodic producers:
:class:`~blinkcan.twin.schedule.Periodic`).

A hook gets what it acts on and the time as arguments and returns what the device sends; it never
reads a clock, and it reaches the twin only through the twin's public methods. Frames a write hook
returns are sent after the SDO reply (or the RPDO) that caused them.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from typing import Any

from blinkcan.devices.objects import Value
from blinkcan.protocol.abort import AbortCode
from blinkcan.protocol.frame import Frame
from blinkcan.protocol.nmt import NmtState

#: an object written (SDO or RPDO): frames to send after the reply, an abort code to refuse the
#: value, or None
WriteHook = Callable[[Any, float], "list[Frame] | AbortCode | None"]
#: an RPDO's data (its length is the frame's DLC): the frames the device sends in reaction
RpdoHook = Callable[[bytes, float], list[Frame]]
#: a frame on a COB-ID the model listens to besides the standard ones (SYNC)
FrameHook = Callable[[Frame, float], list[Frame]]
#: sees a frame before it is acted on
Watcher = Callable[[Frame, float], None]
#: power-on, reset node or reset communication (``application``: power-on or reset node)
BootHook = Callable[[float, bool], list[Frame]]
#: an NMT state change: (previous, new state, now)
StateHook = Callable[[NmtState, NmtState, float], list[Frame]]
#: something to do at ``now``: the frames it sends
Action = Callable[[float], list[Frame]]
#: times at which the twin has work (None: none), asked with the time of the last input
DeadlineSource = Callable[[float], Iterable[float | None]]
#: extra snapshot() entries, asked with the time of the last input
SnapshotHook = Callable[[float], Mapping[str, object]]
#: settings kept in the NVM beside the objects' (the keypad's J1939 settings)
ExtraSettings = Callable[[], Mapping[str, Value]]
