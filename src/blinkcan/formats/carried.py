"""What each log format keeps of a frame, and the count of what a conversion loses.

A frame is its identifier (11 or 29 bits), kind (data, remote with its DLC, error with its
class and data, CAN FD with its BRS and ESI flags), data (0..64 bytes), channel and absolute
time (to the microsecond). Each format below keeps all of that except what its row says; a
writer counts, per frame, what the target loses (:class:`Losses`) so that a conversion names,
counts and explains it instead of changing frames silently. The rows are what blinkcan writes
and reads back (formats/log_writers.py, logs.py), checked against every pair of formats by
tests/formats/test_convert_pairs.py.
"""

from __future__ import annotations

import math
import re
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass

import can

#: the channel a frame that has none (a pcap's, a udp_multicast bus's) is written on where the
#: format names every frame's channel: candump's interface, the numbered formats' channel 1
#: (python-can numbers them from 1: read back as 0, "can0"); said once per file
DEFAULT_CHANNEL = "can0"

#: channels a numbered format keeps: its channel numbers are candump's canN
_NUMBERED = re.compile(r"can(0|[1-9][0-9]*)")


@dataclass(frozen=True)
class Carries:
    """What a format keeps. ``dropped``: kinds of frame it cannot hold at all (not written);
    ``channel``: "name" (any), "number" (canN as N) or "none"; ``times``: "any" order, or
    "from_first" (a frame earlier than the first takes the first's millisecond)."""

    dropped: frozenset[str] = frozenset()
    fd_flag: bool = True  # of a CAN FD frame of up to 8 bytes (longer ones are FD by length)
    bit_rate_switch: bool = True
    error_state: bool = True
    error_details: bool = True  # an error frame's class (its identifier) and data
    channel: str = "number"
    times: str = "any"
    #: the highest canN a numbered format holds (BLF's channel is 16 bits, from 1)
    max_channel: int | None = None


CARRIES: dict[str, Carries] = {
    ".pcap": Carries(channel="none"),  # LINKTYPE_CAN_SOCKETCAN has no interface field
    ".log": Carries(channel="name"),
    ".asc": Carries(error_details=False, times="from_first"),  # "1  ErrorFrame", no class
    ".blf": Carries(times="from_first", max_channel=0xFFFE),
    ".mf4": Carries(),  # frames grouped by kind, read back merged by time
    # TRC 2.1 as formats/log_writers.py writes it: no error frames (python-can reads no ER
    # line), no ESI (python-can and PEAK read FE and BI differently)
    ".trc": Carries(dropped=frozenset({"error"}), error_state=False),
    ".csv": Carries(fd_flag=False, bit_rate_switch=False, error_state=False, channel="none"),
    ".db": Carries(fd_flag=False, bit_rate_switch=False, error_state=False, channel="none"),
}
CARRIES[".cap"] = CARRIES[".pcap"]

#: what is lost -> how the line about it reads: (what the frames lost, why)
LOST = {
    "channel": ("their channel", "{suffix} has no channel"),
    "channel name": ("their channel name", "{suffix} numbers channels: only canN names keep, "
                                           f"the others are on {DEFAULT_CHANNEL}"),
    "channel text": ("their channel name", "{suffix} holds a channel name only as text "
                                           "without spaces or control characters: the others "
                                           f"are on {DEFAULT_CHANNEL}"),
    "fd flag": ("the CAN FD flag", "{suffix} has no CAN FD flag; only frames over 8 bytes "
                                   "read back as CAN FD"),
    "brs": ("the bit rate switch", "{suffix} has no BRS flag"),
    "esi": ("the error state indicator", "{suffix} has no ESI flag"),
    "error details": ("their error class and data", "{suffix} writes an error frame with "
                                                    "its channel and time only"),
    "time": ("their time", "{suffix} cannot hold a time earlier than its first frame's "
                           "millisecond, so it took that time"),
}


def channel_key(channel: object) -> str | None:
    """A channel as candump names it: 1 and "1" are "can1"; None stays None."""
    if channel is None:
        return None
    if isinstance(channel, int) or (isinstance(channel, str) and channel.isascii()
                                    and channel.isdigit()):
        return f"can{int(channel)}"
    return str(channel)


def writable_name(channel: object) -> str | None:
    """``channel``'s candump name where a line of text can hold it as it is: a number, or text
    without spaces or control characters (candump -L's ``(time) name frame`` is split at
    spaces, one frame a line); None for no channel and for any other (a name with a newline
    would split its line, and could write a frame never on the bus; a datagram's dict)."""
    if not isinstance(channel, (str, int)):
        return None
    key = channel_key(channel)
    if not key or not key.isprintable() or any(character.isspace() for character in key):
        return None
    return key


#: the longest channel name a loss line shows as it is
SHOWN = 40


def shown_channel(channel: object) -> str:
    """``channel`` as a loss line names it: its candump name where that is safe text, else
    its Python form (quotes and escapes: ``'a b\\nc'``), cut at :data:`SHOWN` characters."""
    text = writable_name(channel) or repr(channel)
    return text if len(text) <= SHOWN else text[:SHOWN - 3] + "..."


#: BLF's header holds no date before 1990 (python-can's timestamp_to_systemtime): a log of
#: times from 0 starts at 0
BLF_DATED_FROM = 631152000


def start_millisecond(timestamp: float) -> float:
    """The millisecond a format with a millisecond start date starts at (never after
    ``timestamp``)."""
    start = math.floor(timestamp * 1000) / 1000
    return start - 0.001 if start > timestamp else start


def start_of(suffix: str, first: float) -> float:
    """Where the times of a format with a start date count from, its first frame at
    ``first``."""
    if suffix == ".blf" and first < BLF_DATED_FROM:
        return 0.0
    return start_millisecond(first)


class Losses:
    """Per frame written to a format, what it loses: counted by what, with examples."""

    NAMED = 5

    def __init__(self, suffix: str) -> None:
        self.suffix = suffix
        self.carries = CARRIES.get(suffix, Carries(channel="name"))
        self.counts: Counter[str] = Counter()
        self.examples: dict[str, list[str]] = {}
        self._first: float | None = None
        self._channels: dict[str | int, tuple[str | None, str | None]] = {}

    def lost(self, message: can.Message) -> list[str]:
        """What of ``message`` the format loses (see :data:`LOST`)."""
        carries = self.carries
        lost = []
        channel_lost, key = self._channel(message.channel)
        if channel_lost is not None:
            lost.append(channel_lost)
        elif key is None and carries.channel != "none":
            lost.append("no channel")  # not lost: given the stated default
        if message.is_error_frame:
            if not carries.error_details and (message.arbitration_id or any(message.data)):
                lost.append("error details")
        elif message.is_fd:
            if not carries.fd_flag and len(message.data) <= 8:
                lost.append("fd flag")
            if not carries.bit_rate_switch and message.bitrate_switch:
                lost.append("brs")
            if not carries.error_state and message.error_state_indicator:
                lost.append("esi")
        if self._first is None:
            self._first = message.timestamp
        if carries.times == "from_first" and \
                message.timestamp < start_of(self.suffix, self._first):
            lost.append("time")
        return lost

    def _channel(self, channel: object) -> tuple[str | None, str | None]:
        """(what the format loses of ``channel``, how a loss line names it; None: no
        channel), once per channel (a channel that is neither text nor a number, a dict a
        datagram carried, each time: it may be no dictionary key)."""
        hashable = channel if isinstance(channel, (str, int)) else None
        if hashable is not None and hashable in self._channels:
            return self._channels[hashable]
        lost = None
        if channel is not None:
            if self.carries.channel == "none":
                lost = "channel"
            elif self.carries.channel == "number":
                if self.number(channel) is None:
                    lost = "channel name"
            elif writable_name(channel) is None:
                lost = "channel text"
        named = None if channel is None else shown_channel(channel)
        if hashable is not None:
            self._channels[hashable] = lost, named
        return lost, named

    def number(self, channel: object) -> int | None:
        """``channel``'s number in a numbered format (``can3``, ``"3"``, 3: 3); None for a
        name it cannot keep (written on :data:`DEFAULT_CHANNEL`)."""
        if not isinstance(channel, (str, int)):
            return None
        matched = _NUMBERED.fullmatch(channel_key(channel) or "")
        if matched is None:
            return None
        number = int(matched.group(1))
        limit = self.carries.max_channel
        return number if limit is None or number <= limit else None

    def count(self, message: can.Message, describe: Callable[[can.Message], str]) -> None:
        """Count what ``message`` loses; ``describe`` names it ("CAN FD frame 123h")."""
        for what in self.lost(message):
            self.counts[what] += 1
            examples = self.examples.setdefault(what, [])
            if len(examples) < self.NAMED:
                example = self._channel(message.channel)[1] if what.startswith("channel") \
                    else describe(message)
                if example is not None and example not in examples:
                    examples.append(example)

    def lines(self) -> list[str]:
        """One line per thing lost: "3 frames lost their channel (can0, can1): .csv has no
        channel"."""
        lines = []
        for what, count in self.counts.items():
            if what == "no channel":
                lines.append(f"{count} frame{'s' if count != 1 else ''} had no channel: "
                             f"{self.suffix} names every frame's, so "
                             f"{'they are' if count != 1 else 'it is'} on {DEFAULT_CHANNEL}")
                continue
            lost, why = LOST[what]
            if count == 1:
                lost = lost.replace("their ", "its ")
            examples = ", ".join(self.examples.get(what, []))
            lines.append(f"{count} frame{'s' if count != 1 else ''} lost {lost} ({examples}): "
                         + why.format(suffix=self.suffix))
        return lines
