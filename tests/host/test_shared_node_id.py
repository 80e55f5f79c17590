"""Two devices at one node id (issue 17 item 7): a wiring mistake, or two ``blinkcan emulate
keypad`` in two terminals. Every SDO request gets two replies, the second taken for the next
request's ("reply for (4096, 0)", "abort for another object"). Drivers, scan, the command line
and the emulator say what it is: "two devices answer at node 15h"."""

from __future__ import annotations

import time
import uuid
from collections.abc import Iterator
from io import StringIO

import can
import pytest
from click.testing import CliRunner
from rich.console import Console

from blinkcan.cli.emulate import ForeignFrames
from blinkcan.cli.main import cli
from blinkcan.devices.registry import models
from blinkcan.host import IdentityError, SharedNodeIdError, scan, scan_j1939
from blinkcan.host.j1939_keypad import j1939_models
from blinkcan.host.registry import driver_class
from blinkcan.protocol import Frame
from blinkcan.runtime import Emulator
from blinkcan.testing import Rig
from blinkcan.twin import KeyboxTwin, KeypadTwin
from blinkcan.twin.registry import build_twin

MODELS = [model.name for model in models()]


@pytest.mark.parametrize("name", MODELS)
def test_a_driver_says_two_devices_answer(name: str) -> None:
    with Rig() as rig:
        first, second = rig.add(build_twin(name)), rig.add(build_twin(name))
        assert first.node_id == second.node_id
        rig.settle()
        with pytest.raises(SharedNodeIdError, match=rf"^two devices answer at node "
                                                    rf"{first.node_id:02X}h"):
            driver_class(name)(rig.bus, first.node_id)


def test_a_keypad_and_a_keybox_at_one_node_id() -> None:
    with Rig() as rig:
        rig.add(KeypadTwin(node_id=0x15))
        rig.add(KeyboxTwin(node_id=0x15))
        rig.settle()
        for driver in (driver_class("keypad"), driver_class("keybox")):
            with pytest.raises(IdentityError, match="two devices answer at node 15h"):
                driver(rig.bus, 0x15)


def test_one_device_is_still_confirmed_with_late_replies_around() -> None:
    """A reply nobody awaited (another master's) makes the driver count: one device is fine."""
    with Rig() as rig:
        rig.add(KeypadTwin(node_id=0x15))
        rig.settle()
        rig.bus.send(can.Message(arbitration_id=0x595, data=bytes(8), is_extended_id=False))
        keypad = driver_class("keypad")(rig.bus, 0x15)
        assert keypad.confirmed
        keypad.close()


def test_scan_says_two_devices_answer() -> None:
    with Rig() as rig:
        rig.add(KeypadTwin(node_id=0x15))
        rig.add(KeypadTwin(node_id=0x15))
        rig.add(KeyboxTwin())
        found = {f.node_id: f for f in scan(rig.bus, listen=0.05)}
    assert sorted(found) == [0x0C, 0x15]
    assert (found[0x15].answers, found[0x15].shared, found[0x15].kind) == (2, True, "keypad")
    assert found[0x15].describe_shared().startswith("two devices answer at node 15h")
    assert (found[0x0C].answers, found[0x0C].model) == (1, "keybox")


def test_scan_j1939_counts_two_keypads_at_one_address() -> None:
    with Rig() as rig:
        rig.add(KeypadTwin(node_id=0x15, protocol="j1939"))
        rig.add(KeypadTwin(node_id=0x16, protocol="j1939"))
        rig.settle()
        found = scan_j1939(rig.bus, listen=0.2)
    assert [(f.address, f.answers) for f in found] == [(0x21, 2)]


# -- the command line --------------------------------------------------------------------------

@pytest.fixture
def two_terminals() -> Iterator[list[str]]:
    """Two keypads at 15h on one bus (as two ``blinkcan emulate keypad`` would put there). One
    emulator sends both replies to a request back to back, so the second is in before the
    reply to the next request, however loaded the machine: two emulator threads could lag
    each other by more than a request (and the last one could come after the command ended)."""
    channel = f"shared-{uuid.uuid4().hex}"
    bus = can.Bus(interface="virtual", channel=channel)
    with Emulator(bus, [KeypadTwin(node_id=0x15), KeypadTwin(node_id=0x15)]):
        yield ["-i", "virtual", "-c", channel]
    bus.shutdown()


@pytest.mark.parametrize("command", [["keypad", "info"], ["keypad", "led", "1", "red"],
                                     ["keypad", "brightness", "10"], ["scan", "--listen", "0"]])
def test_the_command_line_says_two_devices_answer(two_terminals: list[str],
                                                   command: list[str]) -> None:
    result = CliRunner().invoke(cli, [*command, *two_terminals], env={"COLUMNS": "200"})
    assert result.exit_code != 0
    errors = [line for line in result.output.splitlines() if line.startswith("Error:")]
    assert errors == ["Error: two devices answer at node 15h (one SDO request got 2 replies): "
                      "give each device its own node id"], result.output
    if command[0] != "scan":
        assert result.output.strip() == errors[0]
    else:
        assert "2 devices" in result.output  # the table still lists what answered


def test_emulate_warns_once_when_another_device_uses_its_node_id() -> None:
    output = StringIO()
    twins = [KeypadTwin(node_id=0x15), KeyboxTwin()]
    for twin in twins:
        twin.power_on(0.0)
    foreign = ForeignFrames(twins, Console(file=output, width=300))
    foreign(Frame(0x615, bytes(8)))  # a request to it: anyone may send that
    foreign(Frame(0x716, b"\x00"))  # another node id
    assert output.getvalue() == ""
    foreign(Frame(0x715, b"\x00"))  # a boot-up from 15h that it did not send
    foreign(Frame(0x595, bytes(8)))
    foreign(Frame(0x58C, bytes(8)))  # the Keybox's SDO reply, from elsewhere
    lines = output.getvalue().splitlines()
    assert len(lines) == 2, lines
    assert lines[0].startswith("warning: another device uses node 15h (heard a boot-up on 715h")
    assert lines[1].startswith("warning: another device uses node 0Ch (heard a SDO reply on 58Ch")


def test_emulate_warns_about_a_j1939_address_in_use() -> None:
    output = StringIO()
    keypad = KeypadTwin(node_id=0x15, protocol="j1939")
    keypad.power_on(0.0)
    foreign = ForeignFrames([keypad], Console(file=output, width=300))
    foreign(Frame(0x18EFFF22, bytes(8), extended=True))
    foreign(Frame(0x18EF2100, bytes(8), extended=True))  # a command to it
    assert output.getvalue() == ""
    foreign(Frame(0x18EFFF21, bytes(8), extended=True))
    assert output.getvalue().startswith("warning: another device uses J1939 address 21h")


@pytest.mark.multiprocess
def test_blinkcan_emulate_warns_when_another_device_uses_its_node_id() -> None:
    """``blinkcan emulate keypad`` in a child process; this process sends a heartbeat from 15h,
    as a second ``blinkcan emulate keypad`` in another terminal would. Each wait is for what
    the child sends, with a bound only a failure reaches (8 test suites may share 2 cores)."""
    from blinkcan.runtime import to_message
    from tests.runtime.test_multiprocess import emulated

    with emulated("keypad") as (host, child):
        _wait_for(host, 0x715, "the emulator did not boot")  # its own boot-up: it is running
        for _ in range(3):
            host.send(to_message(Frame(0x715, b"\x05")))  # a heartbeat, operational
        # an SDO read after them: the child takes frames in order, so once it has answered,
        # it has heard the three heartbeats
        host.send(to_message(Frame(0x615, bytes.fromhex("4000100000000000"))))
        _wait_for(host, 0x595, "the emulator did not answer the SDO read")
        child.terminate()
        output = child.communicate(timeout=60)[0].decode()
    warnings = [line for line in output.splitlines() if line.startswith("warning:")]
    assert len(warnings) == 1, output
    assert warnings[0].startswith("warning: another device uses node 15h (heard a heartbeat on "
                                  "715h")


def _wait_for(bus: can.BusABC, can_id: int, failure: str, within: float = 60.0) -> None:
    """Read ``bus`` until a frame with ``can_id`` comes; the test fails saying ``failure``
    if none comes ``within`` seconds."""
    end = time.monotonic() + within
    while time.monotonic() < end:
        message = bus.recv(0.5)
        if message is not None and message.arbitration_id == can_id:
            return
    pytest.fail(failure)


# -- J1939: two keypads at one source address (found by the attack pass of session 7: the
# driver and `blinkcan keypad --protocol j1939 led` went on, every command reaching both) ------

J1939_MODELS = j1939_models()


@pytest.mark.parametrize("name", J1939_MODELS)
def test_a_j1939_driver_says_two_keypads_answer_at_its_address(name: str) -> None:
    with Rig() as rig:
        rig.add(build_twin(name, node_id=0x15, protocol="j1939"))
        rig.add(build_twin(name, node_id=0x16, protocol="j1939"))  # both at 21h (J1939)
        rig.settle()
        asked = rig.now
        with pytest.raises(SharedNodeIdError, match=r"^two keypads answer at J1939 address "
                                                    r"21h \(one software revision request got "
                                                    r"2 replies\): give each its own address"):
            driver_class(name)(rig.bus, protocol="j1939", address=0x21)
        assert rig.now == asked  # the answers due at that instant: no time waited


@pytest.mark.parametrize("name", J1939_MODELS)
def test_one_j1939_keypad_is_confirmed_after_twice_its_round_trip_more(name: str) -> None:
    with Rig(latency=0.001) as rig:
        rig.add(build_twin(name, node_id=0x15, protocol="j1939"))
        rig.add(build_twin(name, node_id=0x16, protocol="j1939", settings={
            "j1939_source_address": 0x22}))
        rig.settle()
        asked = rig.now
        keypad = driver_class(name)(rig.bus, protocol="j1939", address=0x21)
        # the request's round trip (2 ms), then twice as long for a second answer
        assert rig.now - asked == pytest.approx(0.006)
        keypad.set_led(1, "red")
        keypad.close()


@pytest.fixture
def two_j1939_keypads() -> Iterator[list[str]]:
    """Two keypads in J1939 mode at 21h on one bus (two ``blinkcan emulate keypad --protocol
    j1939``), answering from one emulator back to back (see ``two_terminals``)."""
    channel = f"shared-j1939-{uuid.uuid4().hex}"
    bus = can.Bus(interface="virtual", channel=channel)
    with Emulator(bus, [KeypadTwin(node_id=0x15, protocol="j1939"),
                        KeypadTwin(node_id=0x16, protocol="j1939")]):
        yield ["-i", "virtual", "-c", channel]
    bus.shutdown()


@pytest.mark.parametrize("command", [["info"], ["led", "1", "red"], ["brightness", "10"]])
def test_the_command_line_says_two_j1939_keypads_answer(two_j1939_keypads: list[str],
                                                         command: list[str]) -> None:
    result = CliRunner().invoke(cli, ["keypad", "--protocol", "j1939", *command,
                                      *two_j1939_keypads], env={"COLUMNS": "200"})
    assert result.exit_code == 1, result.output
    assert result.output.strip() == (
        "Error: two keypads answer at J1939 address 21h (one software revision request got 2 "
        "replies): give each its own address (address claim, 74h, moves one of them)")
