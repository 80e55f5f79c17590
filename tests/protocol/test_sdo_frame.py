"""parse_sdo: one CiA 301 SDO frame (§7.2.4.3), bytes in, typed fields out."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from blinkcan.errors import BlinkcanError
from blinkcan.protocol.abort import AbortCode
from blinkcan.protocol.sdo import (
    CCS_INITIATE_DOWNLOAD,
    CCS_INITIATE_UPLOAD,
    SCS_INITIATE_UPLOAD,
    SCS_UPLOAD_SEGMENT,
    TOGGLE,
    SdoFrame,
    SdoFrameError,
    multiplexer,
    parse_sdo,
)


def h(text: str) -> bytes:
    return bytes.fromhex(text)


def test_an_upload_request_names_its_object() -> None:
    # PKP §15: read 2000h/01 (keys pressed)
    frame = parse_sdo(h("4000200100000000"))
    assert (frame.specifier, frame.object_index, frame.subindex) == (CCS_INITIATE_UPLOAD,
                                                                     0x2000, 1)
    assert frame.mux == multiplexer(0x2000, 1)


def test_expedited_downloads_carry_the_indicated_bytes() -> None:
    # PKP §16 2Bh: two bytes; KBX §28 23h: four; 22h (no size indicated): all four
    two = parse_sdo(h("2B171000F4010000"))
    assert (two.specifier, two.expedited, two.size_indicated) == (CCS_INITIATE_DOWNLOAD, True,
                                                                  True)
    assert two.expedited_data == h("F401")
    assert two.size is None
    assert parse_sdo(h("231110016C6F6164")).expedited_data == b"load"
    assert parse_sdo(h("2211100101020304")).expedited_data == h("01020304")


def test_an_upload_response_of_one_byte_and_a_segmented_one() -> None:
    one = parse_sdo(h("4F00100005000000"))  # PKP §32: 4Fh, one byte
    assert one.specifier == SCS_INITIATE_UPLOAD
    assert one.expedited_data == b"\x05"
    segmented = parse_sdo(h("410810000B000000"))  # 1008h: eleven bytes follow
    assert (segmented.expedited, segmented.size) == (False, 11)


def test_segments_have_toggle_last_and_their_bytes() -> None:
    first = parse_sdo(h("00426C696E6B4D61"))
    assert (first.specifier, first.toggle, first.last) == (SCS_UPLOAD_SEGMENT, 0, False)
    assert first.segment_data == b"BlinkMa"
    last = parse_sdo(h("1772696E65000000"))  # toggle 1, three bytes unused, last
    assert (last.toggle, last.last, last.segment_data) == (TOGGLE, True, b"rine")


def test_an_abort_has_its_code_in_either_direction() -> None:
    frame = parse_sdo(h("8001100000000206"))  # 0602 0000h for 1001h/00
    assert frame.is_abort
    assert frame.abort_code is AbortCode.OBJECT_DOES_NOT_EXIST
    assert parse_sdo(h("80000000EFBEADDE")).abort_code == 0xDEADBEEF  # not a known code
    assert frame.answers_upload_of(multiplexer(0x1001, 0))
    assert not frame.answers_upload_of(multiplexer(0x1000, 0))


def test_frames_are_immutable_values() -> None:
    assert parse_sdo(h("4000100000000000")) == parse_sdo(bytes(bytearray(h("4000100000000000"))))
    with pytest.raises(AttributeError):
        parse_sdo(h("4000100000000000")).command = 0x80  # type: ignore[misc]


@pytest.mark.parametrize("length", [0, 1, 5, 7, 9])
def test_other_lengths_raise_the_one_documented_error(length: int) -> None:
    with pytest.raises(SdoFrameError, match=f"8 bytes, not {length}"):
        parse_sdo(bytes(length))
    assert issubclass(SdoFrameError, ValueError)
    assert issubclass(SdoFrameError, BlinkcanError)


@given(st.binary(max_size=16))
def test_any_bytes_parse_or_raise_the_one_error(data: bytes) -> None:
    try:
        frame = parse_sdo(data)
    except SdoFrameError:
        assert len(data) != 8
        return
    assert isinstance(frame, SdoFrame)
    assert frame.raw == data
    assert frame.mux == data[1:4]
    assert 0 <= frame.specifier <= 7
    # every view of every layout reads without error and stays inside the frame
    assert len(frame.expedited_data) <= 4
    assert len(frame.segment_data) <= 7
    assert frame.abort_code == int.from_bytes(data[4:8], "little")
    assert frame.size in (None, frame.word)
    assert frame.toggle in (0, TOGGLE)
    assert isinstance(frame.last, bool)
