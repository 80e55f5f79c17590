from __future__ import annotations

import pytest

from blinkcan.protocol import Frame, NmtCommand, NmtState, heartbeat_frame, nmt_frame, parse_nmt
from blinkcan.protocol.nmt import TRANSITIONS, NmtAction


def test_frame_is_immutable_and_equal_by_value() -> None:
    a, b = Frame(0x615, b"\x40"), Frame(0x615, bytearray(b"\x40"))
    assert a == b
    assert hash(a) == hash(b)
    assert type(b.data) is bytes
    with pytest.raises(AttributeError):
        a.can_id = 1  # type: ignore[misc]


@pytest.mark.parametrize(("args", "error"), [
    ((0x800, b""), ValueError), ((0x20000000, b"", True), ValueError), ((-1, b""), ValueError),
    ((1, bytes(9)), ValueError), ((1, "40"), TypeError),
])
def test_frame_rejects_bad_arguments(args: tuple[object, ...], error: type[Exception]) -> None:
    with pytest.raises(error):
        Frame(*args)  # type: ignore[arg-type]


def test_nmt_frames_and_aliases() -> None:
    assert nmt_frame(NmtCommand.START, 0x15) == Frame(0, b"\x01\x15")
    assert parse_nmt(Frame(0, b"\x01\x15")) == (NmtCommand.START, 0x15)
    assert parse_nmt(Frame(0, b"\x00\x15")) is None
    assert parse_nmt(Frame(0, b"\x00\x15"), {0: NmtCommand.STOP}) == (NmtCommand.STOP, 0x15)
    assert parse_nmt(Frame(0, b"\x01")) is None
    assert parse_nmt(Frame(1, b"\x01\x15")) is None
    assert heartbeat_frame(0x0C, NmtState.OPERATIONAL) == Frame(0x70C, b"\x05")


def test_every_state_answers_every_command() -> None:
    for state in (NmtState.PRE_OPERATIONAL, NmtState.OPERATIONAL, NmtState.STOPPED):
        for command in NmtCommand:
            next_state, action = TRANSITIONS[state, command]
            if command is NmtCommand.START:
                assert (next_state, action) == (NmtState.OPERATIONAL, NmtAction.NONE)
