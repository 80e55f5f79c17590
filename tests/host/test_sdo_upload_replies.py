"""A read takes its value from an expedited reply without a transfer object (host/sdo.py
``SdoChannel._upload``); every other first reply goes on exactly as the transfer state machine
(protocol/sdo_client.py) takes it: each expedited size, an abort for the object or for none, a
segmented upload opened, a reply that does not fit, a reply for another object, none at all.
Every registered model's twin, on the Rig; after each, the next read is plain again (in step).

These guard the fast path of session 9 (they also pass on the code before it: each was checked
against a deliberate breakage of the fast path instead)."""

from __future__ import annotations

from collections.abc import Callable

import pytest

from blinkcan.devices.registry import models
from blinkcan.host import HostBus
from blinkcan.protocol.frame import Frame
from blinkcan.protocol.sdo_client import SdoAbortError, SdoProtocolError, SdoTimeoutError
from blinkcan.testing import Rig
from blinkcan.twin.base import CanopenTwin
from blinkcan.twin.registry import build_twin

#: the read every model answers (CiA 301 §7.5.2: 1000h/00, the device type)
_READ_1000 = bytes.fromhex("40001000")
_MUX_1000 = bytes.fromhex("001000")


def _expedited(command: int) -> Callable[[bytes], bytes]:
    """The reply with another expedited command byte: 4Fh-43h state 1-4 bytes, 42h none."""
    return lambda reply: bytes((command,)) + reply[1:]


#: name -> (how the device's first reply to a read of 1000h/00 is rewritten, what the read
#: gives: the value's bytes from the true reply, or the error it raises)
REWRITES: dict[str, tuple[Callable[[bytes], bytes], Callable[[bytes], bytes] | type]] = {
    "as sent": (lambda reply: reply, lambda reply: reply[4:8]),
    "4Fh one byte": (_expedited(0x4F), lambda reply: reply[4:5]),
    "4Bh two bytes": (_expedited(0x4B), lambda reply: reply[4:6]),
    "47h three bytes": (_expedited(0x47), lambda reply: reply[4:7]),
    "43h four bytes": (_expedited(0x43), lambda reply: reply[4:8]),
    "42h no size": (_expedited(0x42), lambda reply: reply[4:8]),
    "abort for the object": (lambda reply: b"\x80" + _MUX_1000 + bytes.fromhex("00000206"),
                             SdoAbortError),
    "abort naming no object": (lambda reply: bytes.fromhex("8000000000000206"), SdoAbortError),
    # a segmented upload opens: the device, which answered expedited, refuses the segment
    # request (CiA 301 §7.2.4.3.17) and the read fails with that abort
    "segmented opened": (lambda reply: b"\x41" + _MUX_1000 + bytes.fromhex("04000000"),
                         SdoAbortError),
    "download acknowledge": (lambda reply: b"\x60" + _MUX_1000 + bytes(4), SdoProtocolError),
    "scs 5": (lambda reply: b"\xa0" + reply[1:], SdoProtocolError),
    # discarded (another object's); no other reply comes: a timeout, then the retry is answered
    "another object": (lambda reply: b"\x43\x18\x10\x02" + reply[4:8],
                       lambda reply: reply[4:8]),
}


def _rewrite_once(twin: CanopenTwin, change: Callable[[bytes], bytes]) -> None:
    """The twin's next SDO reply naming 1000h/00 goes out as ``change`` makes it (its own
    reply filters still apply before)."""
    original = twin.receive
    armed = [True]

    def receive(frame: Frame, now: float) -> list[Frame]:
        replies = original(frame, now)
        if armed[0] and frame.can_id == 0x600 + twin.node_id:
            for i, reply in enumerate(replies):
                if reply.can_id == 0x580 + twin.node_id and reply.data[1:4] == _MUX_1000:
                    armed[0] = False
                    replies = [*replies[:i], Frame(reply.can_id, change(reply.data)),
                               *replies[i + 1:]]
                    break
        return replies

    twin.receive = receive  # type: ignore[method-assign]


@pytest.mark.parametrize("rewrite", list(REWRITES))
@pytest.mark.parametrize("model", [m.name for m in models()])
def test_a_read_takes_its_first_reply_as_the_transfer_does(model: str, rewrite: str) -> None:
    change, expected = REWRITES[rewrite]
    rig = Rig()
    try:
        twin = rig.add(build_twin(model))
        node = twin.node_id
        host = HostBus(rig.bus).start()
        sdo = host.sdo(node, timeout=0.2, retries=1)
        value = sdo.upload(0x1000, 0)
        true_reply = [f.frame.data for f in rig.frames if f.frame.can_id == 0x580 + node][-1]
        _rewrite_once(twin, change)
        start = len(rig.frames)
        if isinstance(expected, type):
            with pytest.raises(expected) as raised:
                sdo.upload(0x1000, 0)
            assert f"node {node:02X}h 1000h/00" in str(raised.value)
            if isinstance(raised.value, SdoAbortError):  # the code of the abort the device sent
                last = [f.frame.data for f in rig.frames[start:]
                        if f.frame.can_id == 0x580 + node][-1]
                assert raised.value.code == int.from_bytes(last[4:8], "little")
        else:
            assert sdo.upload(0x1000, 0) == expected(true_reply)
        if rewrite == "another object":  # the read, its abort after the timeout, the resync
            # read (of 1001h/00: 1000h's reply may still come), the retry
            sent = [f.frame.data[:4] for f in rig.frames[start:] if f.frame.can_id == 0x600 + node]
            assert sent == [_READ_1000, b"\x80" + _MUX_1000, bytes.fromhex("40011000"),
                            _READ_1000]
            assert sdo.channel.late_replies == 1
        assert sdo.upload(0x1000, 0) == value  # in step again
        host.stop()
    finally:
        rig.close()


def test_a_read_without_an_answer_times_out_after_its_retries() -> None:
    """No reply at all: each attempt's read, its abort (CiA 301 §7.2.4.3.17: 0504 0000h), the
    resync read before the retry; then the timeout error (a read is never uncertain)."""
    rig = Rig()
    try:
        twin = rig.add(build_twin("keypad"))
        host = HostBus(rig.bus).start()
        sdo = host.sdo(twin.node_id, timeout=0.2, retries=1)
        rig.power_off(twin)
        start = len(rig.frames)
        with pytest.raises(SdoTimeoutError) as raised:
            sdo.upload(0x1000, 0)
        assert not raised.value.uncertain
        assert "no reply within 0.2 s" in str(raised.value)
        sent = [f.frame.data[:4] for f in rig.frames[start:]
                if f.frame.can_id == 0x600 + twin.node_id]
        assert sent == [_READ_1000, b"\x80" + _MUX_1000, bytes.fromhex("40011000")]
        host.stop()
    finally:
        rig.close()
