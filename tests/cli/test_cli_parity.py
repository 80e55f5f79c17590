"""What works for a CANopen PKP-2600-SI works for a J1939 keypad and the PKP-3500-MT on the
command line, or is refused in one line before the bus (brief hj1939 item 2). Found by the
audit: ``keypad ring 3 1`` sent an NMT start and SDO reads before the encoder number was
checked; ``encoder``, ``read``, ``write``, ``inputs`` checked nothing before the bus; a J1939
heartbeat of 105 ms was reported as set (the keypad counts in 10 ms) and 30 ms reached the bus;
``emulate keypad:0xF0 --protocol j1939`` refused a valid J1939 address (§16: 01h-FDh) as a
CANopen node id; the emulator's own decoder did not know its J1939 keypads' addresses."""

from __future__ import annotations

import click
import pytest

from blinkcan.cli.emulate import build_twins, decoder_devices
from blinkcan.decode import Decoder
from blinkcan.devices.model import Model
from blinkcan.devices.registry import models
from blinkcan.twin import KeypadTwin
from tests.cli.test_arguments_first import _sent, bus_with, empty_bus, error_line, invoke
from tests.conftest import frame

__all__ = ["bus_with", "empty_bus"]  # fixtures

KEYPADS = [m for m in models() if m.kind == "keypad"]
WITH_ENCODERS = [m for m in KEYPADS if m.description().face.encoders]
WITHOUT_ENCODERS = [m for m in KEYPADS if not m.description().face.encoders]
WITH_INPUTS = [m for m in KEYPADS if m.description().face.analog_inputs]
J1939_MODELS = [m for m in models() if "j1939" in m.description().features]


def _encoders(found: Model) -> int:
    return len(found.description().face.encoders)


@pytest.mark.parametrize(("args", "message"), [
    (["keypad", "ring", "3", "1"], "encoder 3 outside 1..2 (any registered keypad)"),
    (["keypad", "ring", "1", "17"], "ring 1 LED 17 outside 1..16"),
    (["keypad", "ring", "2", "1"], "ring 2 LED 1 outside 17..32"),
    (["keypad", "encoder", "3"], "encoder 3 outside 1..2"),
    (["keypad", "encoder", "1", "--top", "1"], "TOP 1 outside 0x0, 0x2..0x10"),
    (["keypad", "encoder", "1", "--counter", "70000"], "counter 70000 outside 0x0..0xffff"),
    (["keypad", "read", "no_such_object"], "no object 'no_such_object'"),
    (["keypad", "read", "encoder_1"], "did you mean encoder_1_direction, encoder_1_ticks"),
    (["keypad", "write", "encoder_1_top", "99"], "takes 0x0, 0x2..0x10, not 99"),
    (["keypad", "write", "device_type", "1"], "is read-only"),
    (["keypad", "write", "analog_period", "x"], "takes 0x8..0xc8, not 'x'"),
    (["keybox", "read", "encoder_1_top"], "no object 'encoder_1_top' (the Keybox)"),
    # J1939 (§18: 75h, period 05h-FEh x 10 ms): the keypad's own range and unit
    (["keypad", "--protocol", "j1939", "heartbeat", "30"],
     "heartbeat period in ms 30 outside 0, 50..2540"),
    (["keypad", "--protocol", "j1939", "heartbeat", "105"],
     "heartbeat period 105 ms is not a multiple of 10 ms"),
    (["keypad", "--protocol", "j1939", "read", "encoder_1_top"],
     "read has no J1939 command on this keypad"),
])
def test_arguments_are_checked_before_the_bus(empty_bus: tuple[str, object], args: list[str],
                                              message: str) -> None:
    channel, sniffer = empty_bus
    line = error_line(invoke(channel, *args))
    assert message in line
    assert sniffer.recv(0.05) is None  # type: ignore[attr-defined]  # the bus saw nothing


@pytest.mark.parametrize("found", WITHOUT_ENCODERS, ids=lambda m: m.name)
@pytest.mark.parametrize("command", [["ring", "1", "1"], ["encoder", "1"]])
def test_a_model_without_encoders_is_refused_before_the_bus(
        empty_bus: tuple[str, object], found: Model, command: list[str]) -> None:
    channel, sniffer = empty_bus
    line = error_line(invoke(channel, "keypad", "--model", found.name, *command))
    assert f"no encoder{' rings' if command[0] == 'ring' else 's'} (the " \
        f"{found.description().title})" in line
    assert sniffer.recv(0.05) is None  # type: ignore[attr-defined]


@pytest.mark.parametrize("found", WITH_ENCODERS, ids=lambda m: m.name)
def test_an_encoder_the_model_lacks_is_refused_before_the_bus(
        empty_bus: tuple[str, object], found: Model) -> None:
    channel, sniffer = empty_bus
    beyond = str(_encoders(found) + 1)
    for command in (["ring", beyond, "1"], ["encoder", beyond]):
        line = error_line(invoke(channel, "keypad", "--model", found.name, *command))
        assert f"encoder {beyond} outside 1..{_encoders(found)}" in line
    assert sniffer.recv(0.05) is None  # type: ignore[attr-defined]


@pytest.mark.parametrize("bus_with", [m.name for m in WITHOUT_ENCODERS if m.generations],
                         indirect=True)
@pytest.mark.parametrize(("command", "what"), [
    (["ring", "1", "1"], "no encoder rings"), (["encoder", "1", "--top", "4"], "no encoders"),
    (["inputs"], "no inputs"), (["read", "encoder_1_top"], "no object 'encoder_1_top'"),
])
def test_the_model_found_is_checked_before_any_command(
        bus_with: tuple[str, object, KeypadTwin], command: list[str], what: str) -> None:
    """A keypad without encoders at 15h: only its identity is read (no NMT start, no SDO
    write, no ring PDO)."""
    channel, sniffer, keypad = bus_with
    line = error_line(invoke(channel, "keypad", *command))
    assert f"{what} (the {keypad.description.title} at node 15h)" in line
    assert _sent(sniffer) == {0x615}  # type: ignore[arg-type]


@pytest.mark.parametrize("found", J1939_MODELS, ids=lambda m: m.name)
def test_emulate_takes_every_j1939_address(found: Model) -> None:
    """DEVICE:ADDR in J1939 mode is a source address, 01h..FDh (§16), not a CANopen node
    id; two keypads at one J1939 address are refused as two at one node id are."""
    twins = build_twins((f"{found.name}:0xF0", f"{found.name}:0x30"), None, None,
                        "firmware", (), "j1939")
    try:
        addresses = []
        for twin in twins:
            twin.power_on(0.0)
            twin.advance(1.0)
            addresses.append(twin.snapshot()["j1939"]["source_address"])
        assert addresses == [0xF0, 0x30]
        decoder = Decoder(decoder_devices(twins))  # the emulator's: its keypads from frame 1
        assert str(decoder.decode(frame("18EFF000 04 1B 2A FF FF FF FF FF"))) == \
            "keypad F0h: software revision request"
        assert str(decoder.decode(frame("18EF3000 04 1B 01 03 01 01 00 FF"))) == \
            "keypad 30h: LED 3 red"
    finally:
        for twin in twins:
            twin.close()
    with pytest.raises(click.UsageError, match="both on J1939 address 30h"):
        build_twins((f"{found.name}:0x30", f"{found.name}:0x30"), None, None, "firmware",
                    (), "j1939")
    with pytest.raises(click.BadParameter, match=r"outside 0x1\.\.0xfd"):
        build_twins((f"{found.name}:0xFE",), None, None, "firmware", (), "j1939")


@pytest.mark.parametrize("found", [m for m in KEYPADS if m not in J1939_MODELS],
                         ids=lambda m: m.name)
@pytest.mark.parametrize("command", [["led", "3", "red"], ["info"], ["heartbeat", "100"]])
def test_a_model_without_j1939_is_refused_over_j1939_before_the_bus(
        empty_bus: tuple[str, object], found: Model, command: list[str]) -> None:
    """``--model pkp-3500-mt --protocol j1939`` said "key 3 outside  (no registered model)",
    or opened the bus and drove the keypad as a PKP-2600-SI."""
    channel, sniffer = empty_bus
    line = error_line(invoke(channel, "keypad", "--protocol", "j1939", "--model", found.name,
                             *command))
    assert f"the {found.description().title} has no J1939 mode (J1939: " in line
    assert sniffer.recv(0.05) is None  # type: ignore[attr-defined]
