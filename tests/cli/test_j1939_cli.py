"""The command line with keypads in J1939 mode: ``keypad --protocol j1939``, ``emulate
--protocol j1939`` (spec/pkp-2600-si-j1939.md)."""

from __future__ import annotations

import uuid
from collections.abc import Iterator

import can
import click
import pytest
from click.testing import CliRunner

from blinkcan.cli.emulate import _name, build_twins
from blinkcan.cli.main import cli
from blinkcan.protocol import Frame
from blinkcan.runtime import Emulator
from blinkcan.runtime.simbus import SimulatedBus
from blinkcan.testing import Rig
from blinkcan.twin import KeypadTwin


@pytest.fixture
def bench() -> Iterator[tuple[str, Emulator, KeypadTwin]]:
    channel = f"cli-j1939-{uuid.uuid4().hex}"
    bus = can.Bus(interface="virtual", channel=channel)
    twin = KeypadTwin(protocol="j1939")
    with Emulator(bus, [twin]) as emulator:
        yield channel, emulator, twin
    bus.shutdown()


def run(*args: str) -> str:
    result = CliRunner().invoke(cli, list(args), env={"COLUMNS": "160"})
    assert result.exit_code == 0, result.output
    return result.output


def test_keypad_commands_over_j1939(bench: tuple[str, Emulator, KeypadTwin]) -> None:
    channel, emulator, twin = bench
    bus = ["-i", "virtual", "-c", channel]
    assert run("keypad", "--protocol", "j1939", *bus, "led", "3", "red") == \
        "keypad 21h (J1939): key 3 red\n"
    assert emulator.snapshot(twin)["commanded"][2]["colour"] == "red"
    run("keypad", "--protocol", "j1939", *bus, "backlight", "--colour", "cyan", "--level", "20")
    run("keypad", "--address", "0x21", *bus, "brightness", "40")  # --address implies J1939
    snapshot = emulator.snapshot(twin)
    assert snapshot["backlight"] == {"colour": "cyan", "level": 20}
    assert snapshot["indicator_brightness"] == 40
    emulator.run(lambda now: twin.receive(
        Frame(0x18EF2100, bytes.fromhex("041B7030FFFFFFFF"), extended=True), now))
    assert run("keypad", "--address", "30h", *bus, "led", "1", "blue", "--blink") == \
        "keypad 30h (J1939): key 1 blinking blue\n"
    assert emulator.snapshot(twin)["commanded"][0]["colour"] == "blue"


def test_a_bad_j1939_address_is_one_line() -> None:
    result = CliRunner().invoke(cli, ["keypad", "--address", "0xFE", "-i", "virtual", "-c",
                                      f"none-{uuid.uuid4().hex}", "led", "1", "red"])
    assert result.exit_code == 2
    assert "01h..FDh" in result.output


def test_emulate_builds_keypads_in_j1939_mode() -> None:
    twins = build_twins(("keypad@1.5",), None, None, "firmware", (), "j1939")
    assert _name(twins[0]) == "PKP-2600-SI keypad 21h (J1939), generation 2 (manual rev 1.5)"
    twins[0].power_on(0.0)
    assert twins[0].snapshot()["protocol"] == "j1939"
    assert _name(build_twins(("keypad",), None, None, "firmware")[0]) \
        == "PKP-2600-SI keypad 15h, generation 1 (manual rev 1.1)"
    with pytest.raises(click.UsageError, match="applies to PKP-2600-SI keypad only"):
        build_twins(("keybox",), None, None, "firmware", (), "j1939")


def test_scan_lists_j1939_keypads_beside_canopen_devices(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """In simulated time (a Rig): scan's waits (0.05 s of listening, 0.2 s per SDO reply) are
    virtual, so every reply is in time however loaded the host is."""
    with Rig() as rig:
        rig.add(KeypadTwin())
        claiming = rig.add(KeypadTwin(protocol="j1939", node_id=0x16))
        rig.act(lambda now: claiming.receive(Frame(
            0x18EF2100, bytes.fromhex("041B7030FFFFFFFF"), extended=True), now))
        rig.act(lambda now: claiming.receive(Frame(
            0x18EF3000, bytes.fromhex("041B7401FFFFFFFF"), extended=True), now))
        rig.power_cycle(claiming)
        monkeypatch.setattr("blinkcan.cli.scan.cli_bus",
                            lambda: SimulatedBus(rig.network, "blinkcan scan"))
        result = CliRunner().invoke(cli, ["scan", "--listen", "0.05"], env={"COLUMNS": "150"})
    assert result.exit_code == 0, result.output
    assert "pkp-2600-si" in result.output  # the CANopen keypad
    row = next(line for line in result.output.splitlines() if "J1939" in line)
    assert "30h" in row
    assert "V2.6" in row
    assert "claimed" in row


def test_one_led_command_leaves_the_other_keys_alone(
        bench: tuple[str, Emulator, KeypadTwin]) -> None:
    """Issue 20 item 1: each run names one key and changes it only (§7a)."""
    channel, emulator, twin = bench
    bus = ["-i", "virtual", "-c", channel]
    run("keypad", "--protocol", "j1939", *bus, "led", "5", "green")
    run("keypad", "--protocol", "j1939", *bus, "led", "3", "red")
    commanded = [key["colour"] for key in emulator.snapshot(twin)["commanded"]]
    assert commanded[2] == "red"
    assert commanded[4] == "green"


def test_info_over_j1939(bench: tuple[str, Emulator, KeypadTwin]) -> None:
    """Issue 20 item 2: the software revision (§11), address and claim, not a CANopen SDO."""
    channel, _emulator, _twin = bench
    output = run("keypad", "--protocol", "j1939", "-i", "virtual", "-c", channel, "info")
    assert "address           21h (J1939)" in output
    assert "software_version  V2.6" in output
    assert "claim             not claimed" in output
    assert "SDO" not in output
    assert "1000h" not in output


def test_no_keypad_at_the_address_is_one_line(
        bench: tuple[str, Emulator, KeypadTwin]) -> None:
    """Issue 20 item 3: J1939 commands are unacknowledged; the CLI hears the keypad first."""
    channel, emulator, twin = bench
    result = CliRunner().invoke(cli, ["keypad", "--address", "0x30", "-i", "virtual", "-c",
                                      channel, "led", "3", "red"])
    assert result.exit_code == 1
    assert result.output == "Error: no keypad heard at 30h\n"
    assert emulator.snapshot(twin)["commanded"][2]["colour"] == "off"


def test_j1939_colours_of_their_own(bench: tuple[str, Emulator, KeypadTwin]) -> None:
    """Issue 20 item 4: §7a 09h yellow/green and 08h amber from the command line, as named."""
    channel, emulator, twin = bench
    bus = ["-i", "virtual", "-c", channel]
    assert run("keypad", "--protocol", "j1939", *bus, "led", "6", "yellow/green",
               "--blink", "amber") == \
        "keypad 21h (J1939): key 6 yellow/green alternating with amber\n"
    assert emulator.snapshot(twin)["commanded"][5]["phases"] == ["yellow/green", "amber"]
    result = CliRunner().invoke(cli, ["keypad", "--protocol", "j1939", *bus, "led", "6",
                                      "purple"])
    assert result.exit_code == 2
    assert "yellow/green" in result.output


@pytest.mark.parametrize("args", [["restore-defaults", "--yes"], ["inputs"],
                                  ["read", "node_id"]])
def test_a_command_j1939_has_not_is_refused_before_the_bus(args: list[str]) -> None:
    """CANopen-only commands over J1939 are refused with one line naming what works, and
    nothing is sent (the bus is never opened: the interface named does not exist)."""
    result = CliRunner().invoke(cli, ["keypad", "--protocol", "j1939", "-i", "no-such-bus",
                                      *args])
    assert result.exit_code == 2
    error = [line for line in result.output.splitlines() if line.startswith("Error:")]
    assert len(error) == 1
    assert error[0].startswith(
        f"Error: {args[0]} has no J1939 command on this keypad; over J1939: info, led, "
        "backlight, brightness, heartbeat, set-node-id (its source address, §16), set-baud "
        "(500000 or 250000 bit/s, §15)")


def test_set_baud_and_set_node_id_over_j1939(bench: tuple[str, Emulator, KeypadTwin]) -> None:
    """§15 baud rate (6Fh, at the next power-on) and §16 source address (70h, at once)."""
    channel, emulator, twin = bench
    bus = ["-i", "virtual", "-c", channel]
    refused = CliRunner().invoke(cli, ["keypad", "--protocol", "j1939", *bus, "set-baud",
                                       "125000", "--yes"])
    assert refused.exit_code == 2
    assert "500000" in refused.output
    assert run("keypad", "--protocol", "j1939", *bus, "set-baud", "500000", "--yes") == \
        "keypad 21h (J1939): bit rate 500000 bit/s stored, in use after the next power-on\n"
    assert emulator.run(lambda now: twin.j1939.settings["baud_rate"]) == 0x02  # §15 500k
    assert run("keypad", "--protocol", "j1939", *bus, "set-node-id", "0x90", "--yes") == \
        "keypad 21h (J1939): source address 90h stored and in use\n"
    assert emulator.snapshot(twin)["j1939"]["source_address"] == 0x90
    assert run("keypad", "--address", "0x90", *bus, "led", "2", "red") == \
        "keypad 90h (J1939): key 2 red\n"
    wrong = CliRunner().invoke(cli, ["keypad", "--address", "0x90", *bus, "set-node-id",
                                     "0xFE", "--yes"])
    assert wrong.exit_code == 2
    assert "01h..FDh" in wrong.output


def test_info_over_j1939_waits_a_heartbeat_period(
        bench: tuple[str, Emulator, KeypadTwin]) -> None:
    """§18: a heartbeat at the default period (100 ms) is heard by info; off, it says how long
    it listened."""
    channel, emulator, twin = bench
    bus = ["-i", "virtual", "-c", channel]
    off = run("keypad", "--protocol", "j1939", *bus, "info")
    assert "heartbeat         not heard within 150 ms (off, or slower)" in off
    emulator.run(lambda now: twin.receive(  # 75h: heartbeat on, 0Ah x 10 ms
        Frame(0x18EF2100, bytes.fromhex("041B75010AFFFFFF"), extended=True), now))
    for _ in range(3):  # whenever info starts within the period
        assert "heartbeat         counter " in run("keypad", "--protocol", "j1939", *bus, "info")


@pytest.fixture
def moved_bench() -> Iterator[tuple[str, Emulator, KeypadTwin]]:
    """A keypad in J1939 mode at 30h, as ``emulate keypad:0x30 --protocol j1939`` runs it."""
    channel = f"cli-j1939-{uuid.uuid4().hex}"
    bus = can.Bus(interface="virtual", channel=channel)
    twin = KeypadTwin(protocol="j1939", settings={"j1939_source_address": 0x30})
    with Emulator(bus, [twin]) as emulator:
        yield channel, emulator, twin
    bus.shutdown()


@pytest.mark.parametrize("where", [["--node-id", "0x30", "led"], ["led", "--node-id", "30h"]])
def test_node_id_over_j1939_is_the_address(
        moved_bench: tuple[str, Emulator, KeypadTwin], where: list[str]) -> None:
    """Before, ``keypad --protocol j1939 --node-id 0x30`` went to 21h (no keypad there: "no
    keypad heard at 21h"; or, worse, another keypad that is there)."""
    channel, emulator, twin = moved_bench
    bus = ["-i", "virtual", "-c", channel]
    assert run("keypad", "--protocol", "j1939", *bus, *where, "3", "red") == \
        "keypad 30h (J1939): key 3 red\n"
    assert emulator.snapshot(twin)["commanded"][2]["colour"] == "red"
    # beside --address, --node-id is its CANopen node id (as the driver takes both)
    assert run("keypad", "--address", "0x30", "--node-id", "0x15", *bus, "brightness", "40") \
        == "keypad 30h (J1939): indicator brightness 40\n"
