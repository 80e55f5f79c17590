"""Arguments first, then the bus (issue 17 item 15): ``keybox on 14`` on an empty bus said "no
device answers at node 0Ch". Every keypad/keybox command checks its arguments against the
models that may answer (``--model``, else every registered model of the kind) before it opens
the bus, then against the model found before it sends a command; questions come after the
device was found."""

from __future__ import annotations

import uuid
from collections.abc import Iterator

import can
import pytest
from click.testing import CliRunner, Result

from blinkcan.cli.main import cli
from blinkcan.protocol import Frame
from blinkcan.runtime import Emulator
from blinkcan.twin import KeyboxTwin, KeypadTwin


def invoke(channel: str, *args: str, answer: str | None = None) -> Result:
    return CliRunner().invoke(cli, [*args, "-i", "virtual", "-c", channel], input=answer,
                              env={"COLUMNS": "200"})


def error_line(result: Result) -> str:
    assert result.exit_code != 0, result.output
    lines = [line for line in result.output.splitlines() if line.strip()]
    assert len(lines) == 1, result.output
    assert lines[0].startswith("Error: "), result.output
    return lines[0]


@pytest.fixture
def empty_bus() -> Iterator[tuple[str, can.BusABC]]:
    """A bus with nothing on it, and a sniffer that hears whatever the command sends."""
    channel = f"empty-{uuid.uuid4().hex}"
    sniffer = can.Bus(interface="virtual", channel=channel)
    yield channel, sniffer
    sniffer.shutdown()


@pytest.mark.parametrize(("args", "message"), [
    (["keybox", "on", "14"], "pin 14 outside 1..13 (the Keybox)"),
    (["keybox", "off", "0"], "pin 0 outside 1..13"),
    (["keybox", "reset", "99"], "pin 99 outside 1..13"),
    (["keybox", "pwm", "12", "150%"], "PWM duty in % 150 outside 0..100"),
    (["keybox", "pwm", "12", "11"], "PWM duty 11 outside 0..10"),
    (["keybox", "pwm", "4,12", "5"], "PWM pin 4 outside 12..13"),
    (["keybox", "heartbeat", "65300"], "heartbeat period in ms 65300 outside 0..65279"),
    (["keybox", "set-baud", "20000"], "bit rate 20000 bit/s is not one of 125000, 250000, "
                                      "500000"),
    (["keypad", "led", "16", "red"], "key 16 outside 1..15 (any registered keypad)"),
    (["keypad", "--model", "pkp-2600-si", "led", "14", "red"],
     "key 14 outside 1..12 (the PKP-2600-SI keypad)"),
    (["keypad", "--model", "pkp-3500-mt", "led", "11", "red"],
     "key 11 outside 2..10, 12..15 (the PKP-3500-MT keypad)"),
    (["keypad", "led", "3", "purple"], "unknown LED colour 'purple'"),
    (["keypad", "led", "3", "red", "--blink", "pink"], "unknown LED colour 'pink'"),
    (["keypad", "brightness", "64"], "brightness 64 outside 0..63"),
    (["keypad", "backlight", "--level", "70"], "backlight level 70 outside 0..63"),
    (["keypad", "backlight", "--colour", "pink"], "unknown backlight colour 'pink'"),
    (["keypad", "heartbeat", "5"], "heartbeat period in ms 5 outside 0, 10..65279"),
    (["keypad", "set-baud", "300000"], "bit rate 300000 bit/s is not one of 20000, 50000"),
    (["keypad", "--protocol", "j1939", "led", "13", "red"],
     "key 13 outside 1..12 (the PKP-2600-SI keypad)"),
    (["keypad", "--model", "keybox", "info"], "'keybox' is not one of"),
])
def test_arguments_are_checked_before_the_bus(empty_bus: tuple[str, can.BusABC],
                                              args: list[str], message: str) -> None:
    channel, sniffer = empty_bus
    line = error_line(invoke(channel, *args))
    assert message in line
    assert "no device answers" not in line
    assert "Go on?" not in line
    assert sniffer.recv(0.05) is None  # the bus saw nothing


@pytest.fixture
def bus_with(request: pytest.FixtureRequest) -> Iterator[tuple[str, can.BusABC, KeypadTwin]]:
    """A keypad of the model ``request.param`` at 15h, a Keybox at 0Ch, and a sniffer."""
    channel = f"found-{uuid.uuid4().hex}"
    device_bus = can.Bus(interface="virtual", channel=channel)
    sniffer = can.Bus(interface="virtual", channel=channel)
    keypad = KeypadTwin(node_id=0x15, model=request.param)
    keypad.power_on(0.0)
    keypad.receive(Frame(0x615, bytes.fromhex("2F14200000000000")), 0.0)  # no startup show
    keypad.power_off()
    with Emulator(device_bus, [keypad, KeyboxTwin()]):
        while sniffer.recv(0.2) is not None:
            pass  # the boot-ups
        yield channel, sniffer, keypad
    sniffer.shutdown()
    device_bus.shutdown()


def _sent(sniffer: can.BusABC) -> set[int]:
    """COB-IDs the command line sent (SDO requests and anything else, replies left out)."""
    ids = set()
    while (message := sniffer.recv(0.05)) is not None:
        if not 0x580 <= message.arbitration_id <= 0x5FF:
            ids.add(message.arbitration_id)
    return ids


@pytest.mark.parametrize(("bus_with", "key", "message"), [
    ("pkp-2600-si", "14", "key 14 outside 1..12 (the PKP-2600-SI keypad at node 15h)"),
    ("pkp-3500-mt", "11", "key 11 outside 2..10, 12..15 (the PKP-3500-MT keypad at node 15h)"),
], indirect=["bus_with"])
def test_the_model_found_checks_before_any_command(
        bus_with: tuple[str, can.BusABC, KeypadTwin], key: str, message: str) -> None:
    channel, sniffer, _ = bus_with
    assert message in error_line(invoke(channel, "keypad", "led", key, "red"))
    assert _sent(sniffer) == {0x615}  # the identity reads only: no NMT start, no LED PDO


@pytest.mark.parametrize("bus_with", ["pkp-3500-mt"], indirect=True)
def test_the_keypad_commands_drive_the_model_found(
        bus_with: tuple[str, can.BusABC, KeypadTwin]) -> None:
    channel, _, keypad = bus_with
    result = invoke(channel, "keypad", "led", "2", "green")
    assert result.exit_code == 0, result.output
    assert result.output.strip() == "keypad 15h: key 2 green"
    assert keypad.snapshot()["keys"][1]["colour"] == "green"


def test_set_node_id_finds_the_device_before_asking(empty_bus: tuple[str, can.BusABC]) -> None:
    channel, _ = empty_bus
    line = error_line(invoke(channel, "keypad", "set-node-id", "0x16", answer="y\n"))
    assert "no device answers at node 15h" in line
    assert "Go on?" not in line


@pytest.mark.parametrize("bus_with", ["pkp-2600-si"], indirect=True)
def test_set_node_id_asks_once_the_device_and_a_free_id_are_found(
        bus_with: tuple[str, can.BusABC, KeypadTwin]) -> None:
    channel, _, keypad = bus_with
    taken = invoke(channel, "keypad", "set-node-id", "0x0C", answer="y\n")
    assert "node id 0Ch is taken" in error_line(taken)  # the Keybox: refused before asking
    declined = invoke(channel, "keypad", "set-node-id", "0x16", answer="n\n")
    assert declined.exit_code != 0
    assert "The keypad will move to node 16h. Go on?" in declined.output
    assert keypad.objects["node_id"] == 0x15
    moved = invoke(channel, "keypad", "set-node-id", "0x16", answer="y\n")
    assert moved.exit_code == 0, moved.output
    assert keypad.objects["node_id"] == 0x16
