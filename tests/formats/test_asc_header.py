"""An ASC log whose header has no "internal events logged" line: python-can's header step ends
at the first line that is no header line and drops it, so the log's first frame was lost with
no word (found by the attack pass of session 9: `date`, `base`, then frames). Every frame of
the log is read, whatever the header holds; the lines of a header are still no frames."""

from __future__ import annotations

import io

import can
import pytest

from blinkcan.formats.text_logs import text_log_messages

FRAMES = ["0.100000 1 123 Rx d 1 00", "0.200000 1 124 Rx d 1 01", "0.300000 1 125 Rx d 1 02"]
DATE = "date Mon Jan 1 00:00:00 2024"
HEADERS = {
    "date and base, then frames": [DATE, "base hex timestamps absolute"],
    "base only": ["base hex timestamps absolute"],
    "no header at all": [],
    "a comment last": [DATE, "base hex timestamps absolute", "// version 9.0.0"],
    "a trigger block, no events line": [DATE, "base hex timestamps absolute",
                                        "Begin Triggerblock Mon Jan 1 00:00:00 2024"],
    "as python-can writes it": [DATE, "base hex timestamps absolute", "internal events logged",
                                "// version 9.0.0",
                                "Begin Triggerblock Mon Jan 1 00:00:00 2024"],
    "no internal events": [DATE, "base hex timestamps absolute", "no internal events logged"],
}


@pytest.mark.parametrize("header", HEADERS)
def test_every_frame_of_an_asc_log_is_read_whatever_its_header(header: str) -> None:
    text = "\n".join([*HEADERS[header], *FRAMES, "End TriggerBlock", ""])
    read = list(text_log_messages(io.StringIO(text), ".asc"))
    messages = [m for m in read if isinstance(m, can.Message)]
    assert len(messages) == len(read)  # no line of it unreadable
    assert [m.arbitration_id for m in messages] == [0x123, 0x124, 0x125]
    assert [round(m.timestamp % 60, 6) for m in messages] == [0.1, 0.2, 0.3]


def test_a_bad_line_after_such_a_header_is_named_and_the_frames_around_it_read() -> None:
    text = "\n".join([DATE, "base hex timestamps absolute", FRAMES[0],
                      "0.150000 1 123 Rx d 1 0G", *FRAMES[1:], ""])
    read = list(text_log_messages(io.StringIO(text), ".asc"))
    ids = [getattr(m, "arbitration_id", None) for m in read]
    assert ids == [0x123, None, 0x124, 0x125]
    assert read[1].number == 4  # type: ignore[union-attr]
