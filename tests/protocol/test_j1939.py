"""J1939 identifiers, NAME and address claim (SAE J1939-21/-81), checked against can-j1939."""

from __future__ import annotations

import j1939
import pytest
from hypothesis import given
from hypothesis import strategies as st

from blinkcan.protocol.j1939 import (
    CLAIM_TIMEOUT_S,
    GLOBAL_ADDRESS,
    NULL_ADDRESS,
    PGN_ADDRESS_CLAIMED,
    AddressClaimer,
    ClaimState,
    J1939Id,
    J1939Name,
    address_claim_frame,
    compose_id,
    next_address,
    parse_id,
    request_frame,
)
from tests.conftest import frame

KEYPAD_NAME = J1939Name.from_bytes(bytes.fromhex("3F426F1A00823CC0"))


@pytest.mark.parametrize(("can_id", "parsed"), [
    (0x18EF2100, J1939Id(6, 0xEF00, 0x00, 0x21)),  # spec §3: command to the keypad
    (0x18EFFF21, J1939Id(6, 0xEF00, 0x21, 0xFF)),  # from the keypad, broadcast
    (0x18A72100, J1939Id(6, 0xA700, 0x00, 0x21)),  # §7b colour 1
    (0x18A62100, J1939Id(6, 0xA600, 0x00, 0x21)),  # §7b colour 2
    (0x18EEFF21, J1939Id(6, 0xEE00, 0x21, 0xFF)),  # §20 address claim
    (0x0CF00400, J1939Id(3, 0xF004, 0x00, 0xFF)),  # PDU2 (EEC1): PS is a group extension
])
def test_identifiers_of_the_spec(can_id: int, parsed: J1939Id) -> None:
    assert parse_id(can_id) == parsed
    assert compose_id(parsed.pgn, parsed.source, parsed.destination, parsed.priority) == can_id


def test_compose_refuses_what_has_no_identifier() -> None:
    with pytest.raises(ValueError, match="PDU2"):
        compose_id(0xF004, 0x21, destination=0x00)
    with pytest.raises(ValueError, match="end in 00h"):
        compose_id(0xEF21, 0x00)
    with pytest.raises(ValueError, match=r"priority must be 0..0x7"):
        compose_id(0xEF00, 0x00, 0x21, priority=8)
    with pytest.raises(ValueError, match="source address"):
        compose_id(0xEF00, 0x100)


@given(st.integers(0, 0x1FFFFFFF))
def test_parse_agrees_with_can_j1939(can_id: int) -> None:
    theirs = j1939.MessageId(can_id=can_id)
    pgn = j1939.ParameterGroupNumber()
    pgn.from_message_id(theirs)
    ours = parse_id(can_id)
    assert (ours.priority, ours.source) == (theirs.priority, theirs.source_address)
    # can-j1939's ParameterGroupNumber drops the reserved bit; its MessageId keeps 18 bits
    if pgn.is_pdu1_format:
        assert ours.pgn | ours.destination == theirs.parameter_group_number
    else:
        assert (ours.pgn, ours.destination) == (theirs.parameter_group_number, GLOBAL_ADDRESS)
    assert compose_id(ours.pgn, ours.source, ours.destination, ours.priority) == can_id


@given(st.integers(0, (1 << 64) - 1))
def test_name_fields_agree_with_can_j1939(value: int) -> None:
    value &= ~(1 << 48)  # can-j1939 always sends the reserved bit as 0
    ours = J1939Name(value)
    theirs = j1939.Name(value=value)
    assert ours.to_bytes() == bytes(theirs.bytes)
    fields = ours.fields()
    fields.pop("reserved")
    assert fields == {name: int(getattr(theirs, name)) for name in fields}
    assert J1939Name.from_fields(**ours.fields()) == ours


def test_the_spec_name_is_arbitrary_address_capable() -> None:
    assert KEYPAD_NAME.arbitrary_address_capable  # J-5
    assert KEYPAD_NAME.to_bytes() == bytes.fromhex("3F426F1A00823CC0")


def test_next_address_wraps_and_runs_out() -> None:
    assert next_address(0x21, ()) == 0x22
    assert next_address(0xFD, ()) == 0x01  # J-5: wrapping from FDh to 01h
    assert next_address(0x21, {0x22, 0x23}) == 0x24
    assert next_address(0x21, range(1, 0xFE)) is None


def _claim(name: J1939Name, source: int) -> bytes:
    return address_claim_frame(name, source).data


def test_a_claim_is_won_after_250_ms() -> None:
    claimer = AddressClaimer(KEYPAD_NAME, 0x21)
    assert claimer.start(0.0) == [frame("18EEFF21 3F 42 6F 1A 00 82 3C C0")]
    claimer.advance(CLAIM_TIMEOUT_S - 0.001)
    assert claimer.state.value == "claiming"
    claimer.advance(CLAIM_TIMEOUT_S)
    assert claimer.state.value == "claimed"


def test_a_lower_name_takes_the_address_and_the_keypad_moves_up() -> None:
    claimer = AddressClaimer(KEYPAD_NAME, 0x21)
    claimer.start(0.0)
    stronger = J1939Name(KEYPAD_NAME.value - 1)
    reply = claimer.receive(address_claim_frame(stronger, 0x21), 0.1)
    assert reply == [address_claim_frame(KEYPAD_NAME, 0x22)]
    assert (claimer.address, claimer.state) == (0x22, ClaimState.CLAIMING)


def test_a_higher_name_is_answered_by_claiming_again() -> None:
    claimer = AddressClaimer(KEYPAD_NAME, 0x21)
    claimer.start(0.0)
    weaker = J1939Name(KEYPAD_NAME.value + 1)
    assert claimer.receive(address_claim_frame(weaker, 0x21), 0.1) == [
        address_claim_frame(KEYPAD_NAME, 0x21)]
    assert claimer.address == 0x21


def test_with_no_address_left_the_keypad_cannot_claim() -> None:
    claimer = AddressClaimer(KEYPAD_NAME, 0x21)
    claimer.start(0.0)
    stronger = J1939Name(0)
    for address in range(1, 0xFE):  # everybody else holds every other address
        if address != 0x21:
            claimer.receive(address_claim_frame(stronger, address), 0.0)
    assert claimer.receive(address_claim_frame(stronger, 0x21), 0.1) == [
        frame("18EEFFFE 3F 42 6F 1A 00 82 3C C0")]
    assert claimer.state is ClaimState.CANNOT_CLAIM
    assert not claimer.active


def test_a_single_address_node_gives_up_at_once() -> None:
    single = J1939Name(KEYPAD_NAME.value & ~(1 << 63))
    claimer = AddressClaimer(single, 0x21)
    claimer.start(0.0)
    assert claimer.receive(address_claim_frame(J1939Name(0), 0x21), 0.1) == [
        address_claim_frame(single, NULL_ADDRESS)]


def test_a_request_for_address_claimed_is_answered() -> None:
    claimer = AddressClaimer(KEYPAD_NAME, 0x21)
    claimer.start(0.0)
    request = request_frame(PGN_ADDRESS_CLAIMED, 0x00)
    assert request == frame("18EAFF00 00 EE 00")
    assert claimer.receive(request, 1.0) == [address_claim_frame(KEYPAD_NAME, 0x21)]
    assert claimer.receive(request_frame(PGN_ADDRESS_CLAIMED, 0x00, 0x22), 1.0) == []
    assert claimer.receive(request_frame(0xFEDA, 0x00), 1.0) == []


@given(st.binary(max_size=8), st.integers(0, 0x1FFFFFFF))
def test_random_frames_never_break_the_claimer(data: bytes, can_id: int) -> None:
    claimer = AddressClaimer(KEYPAD_NAME, 0x21)
    claimer.start(0.0)
    replies = claimer.receive(frame(f"{can_id:08X} {data.hex(' ')}"), 0.1)
    assert all(parse_id(r.can_id).pgn == PGN_ADDRESS_CLAIMED for r in replies)
