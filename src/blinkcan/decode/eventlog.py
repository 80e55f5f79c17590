"""The events a person watches (``monitor``, the panel, the demo): the latest few, heartbeats
and periodic frames folded.

A controller and its devices send a heartbeat every few milliseconds; listed one by one they
push everything else off the screen. A heartbeat that says what the same node's last heartbeat
said replaces that row and counts it ("heartbeat, operational (x15)"). So does a periodic frame
(a TPDO the model's description gives a transmission period: the PKP-3500-MT's analog inputs
every 80 ms, MT §14) that says what the latest row of the same PDO and node says; one that says
something new is a new row. Times are shown from the first event on, not as the log's raw
epoch seconds.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

from blinkcan.decode.decoder import Decoder, Event, Kind


@dataclass(frozen=True)
class Row:
    """One line of the log: an event, and how many equal heartbeats it stands for."""

    event: Event
    count: int = 1

    def text(self) -> str:
        return str(self.event) + (f" (x{self.count})" if self.count > 1 else "")


class EventLog:
    """The latest ``rows`` events, repeated heartbeats folded into one row per node; with the
    ``decoder`` that made the events (it knows each node's model), unchanged periodic frames
    too."""

    def __init__(self, rows: int, decoder: Decoder | None = None) -> None:
        if rows < 1:
            raise ValueError(f"rows must be 1 or more, not {rows}")
        self.rows: deque[Row] = deque(maxlen=rows)
        self.start: float | None = None
        self.decoder = decoder

    def add(self, event: Event) -> Row:
        """Keep ``event``; the row it made, or the folded row that now counts it too."""
        if self.start is None:
            self.start = event.time
        if event.kind is Kind.HEARTBEAT:
            for row in self.rows:
                previous = row.event
                if previous.kind is Kind.HEARTBEAT and previous.node_id == event.node_id \
                        and previous.text == event.text:
                    return self._fold(row, event)
        elif self._periodic(event):
            pdo = event.fields.get("pdo")
            for row in reversed(self.rows):
                previous = row.event
                if previous.node_id == event.node_id and previous.kind is Kind.PDO \
                        and previous.fields.get("pdo") == pdo:
                    if previous.text == event.text:
                        return self._fold(row, event)
                    break
        self.rows.append(made := Row(event))
        return made

    def _fold(self, row: Row, event: Event) -> Row:
        self.rows.remove(row)
        self.rows.append(folded := Row(event, row.count + 1))
        return folded

    def _periodic(self, event: Event) -> bool:
        """A PDO the node's model repeats by itself (its layout names a period)."""
        if event.kind is not Kind.PDO or event.node_id is None or self.decoder is None:
            return False
        description = self.decoder.device(event.node_id)
        name = event.fields.get("pdo")
        return description is not None and any(
            layout.name == name and layout.period for layout in description.tx_pdos)

    def since_start(self, event: Event) -> float:
        """Seconds from the first event to ``event``."""
        return event.time - (self.start if self.start is not None else event.time)
