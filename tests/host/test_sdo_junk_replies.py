"""A frame on the SDO reply identifier that cannot answer the request (malformed, or a reply
for another object: another device's, or a stale one) is discarded and counted, and the request
waits for its own reply; a reply that names the object but does not fit fails that request
only, and the channel gets back in step before the next one, as after a timeout (found by the
attack pass of session 5: one junk frame on 58Ch failed every later request with "unexpected
reply 60h" and the driver's output picture stayed wrong)."""

from __future__ import annotations

import pytest

from blinkcan import Keybox
from blinkcan.protocol import Frame
from blinkcan.protocol.sdo_client import SdoProtocolError
from blinkcan.testing import Rig
from blinkcan.twin import KeyboxTwin

JUNK = [b"", b"\x60", b"\x4f\x00\x10\x00\x01", b"\x60\x01\x20\x05\x00\x00\x00\x00",
        b"\x43\x08\x20\x02\x00\x10\x00\x00", b"\x20\x00\x00\x00\x00\x00\x00\x00"]


def _junk_beside_one_reply(twin: KeyboxTwin, junk: bytes, before: bool) -> None:
    """The next SDO reply of ``twin`` comes with ``junk`` before or after it (once)."""
    original = twin.receive
    armed = [True]

    def receive(frame: Frame, now: float) -> list[Frame]:
        replies = list(original(frame, now))
        if armed[0] and frame.can_id == 0x600 + twin.node_id and replies:
            armed[0] = False
            extra = Frame(0x580 + twin.node_id, junk)
            replies = [extra, *replies] if before else [*replies, extra]
        return replies

    twin.receive = receive  # type: ignore[method-assign]


@pytest.mark.parametrize("before", [True, False], ids=["before", "after"])
@pytest.mark.parametrize("junk", JUNK, ids=[j.hex() or "empty" for j in JUNK])
def test_a_frame_that_cannot_be_the_reply_is_discarded(junk: bytes, before: bool) -> None:
    rig = Rig()
    try:
        twin = rig.add(KeyboxTwin(node_id=0x0C))
        keybox = Keybox(rig.bus, 0x0C)
        late = keybox.sdo.channel.late_replies
        _junk_beside_one_reply(twin, junk, before)
        keybox.on(4)
        for pin in (5, 6, 7):
            keybox.on(pin)
            keybox.off(pin)
        pins = {p["pin"]: p["state"] for p in twin.snapshot()["pins"]}
        assert keybox.states() == pins
        assert keybox.actual == pins
        assert keybox.sdo.channel.late_replies == late + 1  # the junk or the reply it stood for
    finally:
        rig.close()


def test_a_reply_naming_the_object_that_does_not_fit_fails_one_request() -> None:
    rig = Rig()
    try:
        twin = rig.add(KeyboxTwin(node_id=0x0C))
        keybox = Keybox(rig.bus, 0x0C)
        # a segment acknowledge (20h) naming the object written (2001h/04), before its own reply
        _junk_beside_one_reply(twin, b"\x20\x01\x20\x04\x00\x00\x00\x00", before=True)
        with pytest.raises(SdoProtocolError, match="2001h/04"):
            keybox.on(4)
        for pin in (5, 6, 7):
            keybox.on(pin)
        pins = {p["pin"]: p["state"] for p in twin.snapshot()["pins"]}
        assert keybox.states() == pins
        assert [pins[p] for p in (4, 5, 6, 7)] == ["high"] * 4
    finally:
        rig.close()
