"""``blinkcan keybox on/off/reset/pwm`` say what the Keybox shows, read back after the
command: an output switched HIGH onto a blown fuse goes FAULT (KBX §7, §18), and an
acknowledge lost on the bus leaves the command applied or not (``SdoTimeoutError.uncertain``).
The command line reported "output 6 HIGH" and exit 0 for an output the Keybox showed in
FAULT, and for a lost acknowledge said only that the write may or may not have been applied,
leaving the user to guess what the load is doing (hatk10's attack pass)."""

from __future__ import annotations

import uuid
from collections.abc import Iterator

import can
import pytest
from click.testing import CliRunner, Result

from blinkcan.cli.main import cli
from blinkcan.protocol import Frame
from blinkcan.runtime import Emulator
from blinkcan.twin import KeyboxTwin

#: SDO downloads of the output commands: 2001h (per pin), 2008h (masks), 2009h (PWM)
_OUTPUT_OBJECTS = (b"\x01\x20", b"\x08\x20", b"\x09\x20")


def _output_write(frame: Frame) -> bool:
    return frame.data[0] & 0xE0 == 0x20 and bytes(frame.data[1:3]) in _OUTPUT_OBJECTS


class LostAcknowledge(KeyboxTwin):
    """A Keybox whose acknowledges of output commands are lost on the bus (it applies them)."""

    def receive(self, frame: Frame, now: float) -> list[Frame]:
        replies = super().receive(frame, now)
        return [] if frame.can_id == 0x600 + self.node_id and _output_write(frame) else replies


class LostCommand(KeyboxTwin):
    """A Keybox that never hears the output commands (lost on their way to it)."""

    def receive(self, frame: Frame, now: float) -> list[Frame]:
        if frame.can_id == 0x600 + self.node_id and _output_write(frame):
            return []
        return super().receive(frame, now)


Bench = tuple[list[str], Emulator, KeyboxTwin]


def _bench(twin: KeyboxTwin) -> Iterator[Bench]:
    channel = f"read-back-{uuid.uuid4().hex}"
    bus = can.Bus(interface="virtual", channel=channel)
    with Emulator(bus, [twin]) as emulator:
        yield ["-i", "virtual", "-c", channel], emulator, twin
    bus.shutdown()


@pytest.fixture
def keybox() -> Iterator[Bench]:
    yield from _bench(KeyboxTwin())


@pytest.fixture
def lost_acknowledge() -> Iterator[Bench]:
    yield from _bench(LostAcknowledge())


@pytest.fixture
def lost_command() -> Iterator[Bench]:
    yield from _bench(LostCommand())


def invoke(*args: str) -> Result:
    return CliRunner().invoke(cli, list(args), env={"COLUMNS": "200"})


def _state(emulator: Emulator, twin: KeyboxTwin, pin: int) -> str:
    return str(emulator.snapshot(twin)["pins"][pin - 1]["state"])


def _onto_a_blown_fuse(bench: Bench, pin: int, *command: str) -> Result:
    """``blinkcan keybox COMMAND...`` once ``pin``'s fuse is blown."""
    bus, emulator, twin = bench
    emulator.run(lambda now: twin.blow_fuse(pin, now))
    return invoke("keybox", *command, *bus)


@pytest.mark.parametrize(("pin", "command"), [(6, ["on", "6"]), (12, ["pwm", "12", "30%"])])
def test_an_output_switched_onto_a_blown_fuse_is_a_fault_not_high(
        keybox: Bench, pin: int, command: list[str]) -> None:
    result = _onto_a_blown_fuse(keybox, pin, *command)
    _, emulator, twin = keybox
    assert _state(emulator, twin, pin) == "fault"
    assert result.exit_code == 1, result.output
    assert "HIGH" not in result.output.replace("switched HIGH", "")
    assert result.output.startswith(f"Error: keybox 0Ch: output {pin} went FAULT"), \
        result.output
    assert f"keybox reset {pin}" in result.output
    assert len(result.output.splitlines()) == 1


def test_commands_that_did_what_they_said_still_say_it(keybox: Bench) -> None:
    bus, emulator, twin = keybox
    for args, said, state in ((["on", "4"], "output 4 HIGH", "high"),
                              (["off", "4"], "output 4 OFF", "off"),
                              (["pwm", "12", "30%"], "output 12 PWM at 30 %", "high"),
                              (["pwm", "12", "0"], "output 12 PWM at 0 %", "off")):
        result = invoke("keybox", *args, *bus)
        assert result.exit_code == 0, result.output
        assert result.output == f"keybox 0Ch: {said}\n"
        assert _state(emulator, twin, int(args[1])) == state


def test_a_reset_of_an_output_still_in_fault_says_so(keybox: Bench) -> None:
    """RESET of a pin whose fuse is still blown and that is driven again goes FAULT again
    only when switched HIGH: a RESET itself leaves it OFF (KBX §7)."""
    _onto_a_blown_fuse(keybox, 6, "on", "6")
    result = invoke("keybox", "reset", "6", *keybox[0])
    assert result.exit_code == 0, result.output
    assert result.output == "keybox 0Ch: output 6 RESET (now OFF)\n"


@pytest.mark.parametrize(("args", "said", "state"), [
    (["on", "4"], "output 4 HIGH", "high"),
    (["pwm", "13", "50%"], "output 13 PWM at 50 %", "high"),
])
def test_a_lost_acknowledge_of_an_applied_command_is_read_back(
        lost_acknowledge: Bench, args: list[str], said: str, state: str) -> None:
    bus, emulator, twin = lost_acknowledge
    result = invoke("keybox", *args, *bus)
    assert _state(emulator, twin, int(args[1])) == state
    assert result.exit_code == 0, result.output
    lines = result.output.splitlines()
    assert lines[0] == f"keybox 0Ch: {said}"
    assert "acknowledge was lost" in lines[1], result.output
    assert "read back" in lines[1], result.output


def test_a_lost_command_is_an_error_naming_what_the_keybox_shows(lost_command: Bench) -> None:
    bus, emulator, twin = lost_command
    result = invoke("keybox", "on", "4", *bus)
    assert _state(emulator, twin, 4) == "off"
    assert result.exit_code == 1, result.output
    assert result.output.startswith("Error: node 0Ch 2001h/04: no reply"), result.output
    assert "read back: output 4 is OFF" in result.output
    assert len(result.output.splitlines()) == 1


def test_off_leaves_a_fault_latched_and_says_so(keybox: Bench) -> None:
    """errata K12: only RESET clears FAULT; ``keybox off 6`` said "output 6 OFF"."""
    _onto_a_blown_fuse(keybox, 6, "on", "6")
    bus, emulator, twin = keybox
    result = invoke("keybox", "off", "6", *bus)
    assert _state(emulator, twin, 6) == "fault"
    assert result.exit_code == 1, result.output
    assert result.output.startswith("Error: keybox 0Ch: output 6 stays FAULT: OFF does not "
                                    "clear a fault"), result.output
    assert "keybox reset 6" in result.output
