"""The events a person watches (``monitor``, the panel): the latest few, heartbeats folded.

A controller and its devices send a heartbeat every few milliseconds; listed one by one they
push everything else off the screen. A heartbeat that says what the same node's last heartbeat
said replaces that row and counts it ("heartbeat, operational (x15)"). Times are shown from the
first event on, not as the log's raw epoch seconds.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

from blinkcan.decode.decoder import Event, Kind


@dataclass(frozen=True)
class Row:
    """One line of the log: an event, and how many equal heartbeats it stands for."""

    event: Event
    count: int = 1

    def text(self) -> str:
        return str(self.event) + (f" (x{self.count})" if self.count > 1 else "")


class EventLog:
    """The latest ``rows`` events, repeated heartbeats folded into one row per node."""

    def __init__(self, rows: int) -> None:
        if rows < 1:
            raise ValueError(f"rows must be 1 or more, not {rows}")
        self.rows: deque[Row] = deque(maxlen=rows)
        self.start: float | None = None

    def add(self, event: Event) -> None:
        if self.start is None:
            self.start = event.time
        if event.kind is Kind.HEARTBEAT:
            for row in self.rows:
                previous = row.event
                if previous.kind is Kind.HEARTBEAT and previous.node_id == event.node_id \
                        and previous.text == event.text:
                    self.rows.remove(row)
                    self.rows.append(Row(event, row.count + 1))
                    return
        self.rows.append(Row(event))

    def since_start(self, event: Event) -> float:
        """Seconds from the first event to ``event``."""
        return event.time - (self.start if self.start is not None else event.time)
