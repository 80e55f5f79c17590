"""Command line: one-line errors everywhere, bus options before or after the subcommand, the
default bus, and the commands for NMT, PWM, restore defaults and generation-2 keypads."""

from __future__ import annotations

import uuid
from collections.abc import Iterator
from pathlib import Path

import can
import click
import pytest
from click.testing import CliRunner, Result

from blinkcan.cli.bus_options import (
    DEFAULT_GROUP,
    DEFAULT_PORT,
    bus_options,
    bus_settings,
    spread_bus_kwargs,
)
from blinkcan.cli.main import cli
from blinkcan.runtime import Emulator
from blinkcan.twin import KeyboxTwin, KeypadTwin
from tests.host.conftest import quiet_keypad, wait_until

Bench = tuple[list[str], Emulator, KeypadTwin, KeyboxTwin]


@pytest.fixture
def bench() -> Iterator[Bench]:
    channel = f"cli-{uuid.uuid4().hex}"
    bus = can.Bus(interface="virtual", channel=channel)
    keypad, keybox = quiet_keypad(), KeyboxTwin()
    with Emulator(bus, [keypad, keybox]) as emulator:
        yield ["-i", "virtual", "-c", channel], emulator, keypad, keybox
    bus.shutdown()


def invoke(*args: str, answer: str | None = None) -> Result:
    return CliRunner().invoke(cli, list(args), input=answer, env={"COLUMNS": "200"})


def run(*args: str, answer: str | None = None) -> str:
    result = invoke(*args, answer=answer)
    assert result.exit_code == 0, result.output
    return result.output


def assert_one_line_error(result: Result, message: str) -> None:
    assert result.exit_code != 0, result.output
    assert "Traceback" not in result.output
    errors = [line for line in result.output.splitlines() if line.startswith("Error:")]
    assert len(errors) == 1, result.output
    assert [line for line in result.output.splitlines() if line.strip()
            and not line.startswith("WARNING")] == errors, result.output
    assert message in errors[0], result.output


# -- item 13: one-line errors --------------------------------------------------------------

@pytest.mark.parametrize(("args", "message"), [
    (["keypad", "--node-id", "0x80", "info"], "node id 0x80 outside 0x01..0x7f"),
    (["keypad", "--node-id", "0", "info"], "node id 0x0 outside"),
    (["keypad", "--node-id", "-1", "info"], "node id -0x1 outside"),
    (["keybox", "--node-id", str(10**30), "info"], "outside 0x01..0x7f"),
    (["emulate", "keypad", "--response-delay", "-1"], "--response-delay"),
    (["emulate", "keypad", "--node-id", "200"], "node id 0xc8 outside"),
    (["scan", "-i", "kvaser"], "needs 'channel' (-c CHANNEL"),
    (["export", "dbc", "keypad", "--node-id", "0x99"], "node id 0x99 outside"),
    (["emulate", "keypad", "keypad"], "keypad and keypad both on node 15h"),
    (["emulate", "keypad:0x0C", "keybox"], "keypad and keybox both on node 0Ch"),
    (["emulate", "keybox@2.0"], "keybox generations are 1.0"),
    (["emulate", "keypad@9.9"], "9.9"),
    (["nmt", "start", "0x80"], "node id 0x80 outside"),
    (["keybox", "pwm", "12", "55%"], "not a step of 10 %"),
    (["scan", "--bus-kwargs", "=1"], "'=1' is not NAME=VALUE"),
    (["keypad", "led", "3", "red", "--node-id", "0x80"], "node id 0x80 outside"),
    (["scan", "--listen", "-1"], "--listen"),
    (["monitor", "--rows", "0"], "--rows"),
    (["monitor", "--duration", "-1"], "--duration"),
    (["record", "x.pcap", "--duration", "-1"], "--duration"),
])
def test_mistakes_are_one_line_and_a_non_zero_exit(args: list[str], message: str) -> None:
    assert_one_line_error(invoke(*args), message)


@pytest.mark.parametrize("command", [
    ["export", "eds", "keypad", "-o"],
    ["convert", "LOG"],
    ["record", "--duration", "0.1", "-i", "virtual", "-c", "nothing-here"],
])
@pytest.mark.parametrize(("directory", "message"), [
    ("missing", "does not exist"),
    ("/sys", "Permission denied"),  # read-only even for root
])
def test_a_file_into_a_missing_or_read_only_directory_is_one_line(
        tmp_path: Path, command: list[str], directory: str, message: str) -> None:
    if directory == "/sys" and not Path("/sys").is_dir():
        pytest.skip("no /sys here")
    log = tmp_path / "in.log"
    log.write_text("(0.0) vcan0 715#00\n")
    target = str(tmp_path / "missing" / "out.log" if directory == "missing"
                 else Path(directory) / "blinkcan-out.log")
    args = [str(log) if a == "LOG" else a for a in command]
    result = invoke(*args, target)
    assert_one_line_error(result, f"cannot write {target}")
    assert message in result.output


# -- item 13: bus options anywhere, --bus-kwargs, actions say what they did -------------------

def test_bus_options_work_before_and_after_the_subcommand(bench: Bench) -> None:
    bus, emulator, keypad, _ = bench
    assert run("keypad", "led", "3", "red", *bus).strip() == "keypad 15h: key 3 red"
    assert run(*bus, "keypad", "led", "4", "green").strip() == "keypad 15h: key 4 green"
    assert run("keypad", *bus, "led", "5", "blue").strip() == "keypad 15h: key 5 blue"
    wait_until(lambda: emulator.snapshot(keypad)["keys"][4]["colour"] == "blue")
    # the one nearest the command wins
    run("-i", "virtual", "-c", "nobody-listens", "keybox", "on", "3", *bus)
    # the node id too may follow the command
    assert run("keybox", "--node-id", "0x33", "on", "2", "--node-id", "0x0C", *bus).strip() == (
        "keybox 0Ch: output 2 HIGH")


def test_bus_kwargs_as_python_can_takes_them() -> None:
    assert spread_bus_kwargs(["scan", "--bus-kwargs", "port=43114", "hop_limit=0", "-q"]) == [
        "scan", "--bus-kwargs", "port=43114", "--bus-kwargs", "hop_limit=0", "-q"]
    seen: dict[str, object] = {}

    @click.command()
    @bus_options
    def probe() -> None:
        seen.update(bus_settings())

    result = CliRunner().invoke(probe, ["-i", "udp_multicast", "--bus-kwargs", "port=43114",
                                        "--bus-kwargs", "hop_limit=0", "--bus-kwargs",
                                        "fd=False"])
    assert result.exit_code == 0, result.output
    assert seen == {"interface": "udp_multicast", "port": 43114, "hop_limit": 0, "fd": False}


def test_keypad_actions_say_what_they_did(bench: Bench) -> None:
    bus, emulator, keypad, _ = bench
    assert run("keypad", "led", "3", "red", "--blink", "green", *bus).strip() == (
        "keypad 15h: key 3 red alternating with green")
    assert run("keypad", "backlight", "--colour", "cyan", "--level", "20", *bus).strip() == (
        "keypad 15h: backlight colour cyan, level 20")
    assert run("keypad", "brightness", "40", *bus).strip() == (
        "keypad 15h: indicator brightness 40")
    assert run("keypad", "heartbeat", "200", *bus).strip() == (
        "keypad 15h: heartbeat every 200 ms")
    assert run("keypad", "set-node-id", "0x22", "--yes", *bus).strip() == (
        "keypad 15h: node id 22h stored")
    assert emulator.snapshot(keypad)["settings"]["node_id"] == 0x22


def test_keybox_actions_say_what_they_did(bench: Bench) -> None:
    bus, emulator, _, keybox = bench
    emulator.run(lambda now: keybox.blow_fuse(6, now))
    assert run("keybox", "on", "5", *bus).strip() == "keybox 0Ch: output 5 HIGH"
    assert run("keybox", "off", "5", *bus).strip() == "keybox 0Ch: output 5 OFF"
    assert run("keybox", "reset", "5", *bus).strip() == "keybox 0Ch: output 5 RESET (now OFF)"
    switched = invoke("keybox", "on", "6", *bus)  # onto the blown fuse: FAULT, read back
    assert switched.exit_code == 1
    assert switched.output.startswith("Error: keybox 0Ch: output 6 went FAULT when switched "
                                      "HIGH")
    assert run("keybox", "faults", *bus).strip() == "6"
    assert run("keybox", "set-baud", "250000", "--yes", *bus).strip() == (
        "keybox 0Ch: bit rate 250000 bit/s stored, in use after the next reset")


# -- item 12: the default bus ------------------------------------------------------------------

def test_with_no_bus_configured_the_cli_uses_udp_multicast_with_hop_limit_0(
        monkeypatch: pytest.MonkeyPatch) -> None:
    for name in ("CAN_INTERFACE", "CAN_CHANNEL", "CAN_BITRATE", "CAN_CONFIG"):
        monkeypatch.delenv(name, raising=False)
    monkeypatch.setattr(can.util, "CONFIG_FILES", [])
    seen: dict[str, object] = {}

    @click.command()
    @bus_options
    def probe() -> None:
        seen.update(bus_settings())

    assert CliRunner().invoke(probe, []).exit_code == 0
    assert seen == {"interface": "udp_multicast", "channel": DEFAULT_GROUP,
                    "port": DEFAULT_PORT, "hop_limit": 0}
    seen.clear()
    assert CliRunner().invoke(probe, ["--bus-kwargs", "port=40001"]).exit_code == 0
    assert seen["port"] == 40001
    assert seen["hop_limit"] == 0


# -- item 14: the missing commands ---------------------------------------------------------------

def test_emulate_a_generation_2_keypad() -> None:
    from blinkcan.cli.emulate import build_twins

    twins = build_twins(("keypad@1.5", "keypad:0x16", "keybox"), None, None, "firmware")
    assert [(t.description.kind, t.description.generation, t.node_id) for t in twins] == [
        ("keypad", "1.5", 0x15), ("keypad", "1.1", 0x16), ("keybox", "1.0", 0x0C)]


def test_keybox_pwm(bench: Bench) -> None:
    bus, emulator, _, keybox = bench
    assert run("keybox", "pwm", "12", "5", *bus).strip() == "keybox 0Ch: output 12 PWM at 50 %"
    assert emulator.snapshot(keybox)["pins"][11]["pwm_percent"] == 50
    assert run("keybox", "pwm", "12,13", "30%", *bus).strip() == (
        "keybox 0Ch: output 12 and 13 PWM at 30 %")
    assert [emulator.snapshot(keybox)["pins"][i]["pwm_percent"] for i in (11, 12)] == [30, 30]
    assert_one_line_error(invoke("keybox", "pwm", "4", "5", *bus), "PWM pin 4 outside 12..13")
    # a pin named twice is one pin (was "output 13 and 13")
    assert run("keybox", "pwm", "13,13", "2", *bus).strip() == "keybox 0Ch: output 13 PWM at 20 %"


def test_nmt_commands(bench: Bench) -> None:
    bus, emulator, keypad, keybox = bench

    def states() -> tuple[str, str]:
        return emulator.snapshot(keypad)["nmt_state"], emulator.snapshot(keybox)["nmt_state"]

    assert run("nmt", "start", "all", "--listen", "0", *bus).strip() == (
        "sent NMT start to every node")
    wait_until(lambda: states() == ("operational", "operational"))
    run("nmt", "stop", "0x15", "--listen", "0", *bus)
    wait_until(lambda: states() == ("stopped", "operational"))
    run("nmt", "pre-operational", "0Ch", "--listen", "0", *bus)
    wait_until(lambda: states() == ("stopped", "pre-operational"))
    output = run("nmt", "reset", "0x15", "--listen", "0.5", *bus)
    assert output.splitlines() == ["sent NMT reset node to node 15h", "node 15h: boot-up"]
    output = run("nmt", "reset-communication", "12", "--listen", "0.5", *bus)
    assert output.splitlines() == ["sent NMT reset communication to node 0Ch",
                                   "node 0Ch: boot-up"]


def test_restore_defaults_asks_first(bench: Bench) -> None:
    bus, emulator, _, keybox = bench
    run("keybox", "heartbeat", "300", *bus)
    result = invoke("keybox", "restore-defaults", *bus, answer="n\n")
    assert result.exit_code == 0  # "n" is an answer, not an error (issue 20 item 14)
    assert result.output.splitlines()[-1].endswith(": nothing changed")
    assert "Error" not in result.output
    assert emulator.snapshot(keybox)["heartbeat_ms"] == 300
    output = run("keybox", "restore-defaults", *bus, answer="y\n")
    assert output.splitlines()[-1] == (
        "keybox 0Ch: factory defaults restored; they apply at the next reset")
    assert emulator.snapshot(keybox)["heartbeat_ms"] == 0  # reads return them at once
    assert_one_line_error(invoke("keypad", "restore-defaults", "--yes", *bus),
                          "cannot restore defaults")


def test_one_colour_blinks_from_the_command_line(bench: Bench) -> None:
    bus, emulator, keypad, _ = bench
    assert run("keypad", "led", "3", "blue", "--blink", *bus).strip() == (
        "keypad 15h: key 3 blinking blue")
    wait_until(lambda: emulator.snapshot(keypad)["keys"][2]["phases"] == ["blue", "off"])
    run("keypad", "led", "4", "green", "--blink", "green", *bus)
    wait_until(lambda: emulator.snapshot(keypad)["keys"][3]["phases"] == ["green", "off"])


def test_scan_that_finds_nothing_names_the_bus_it_listened_on() -> None:
    channel = f"empty-{uuid.uuid4().hex}"
    assert_one_line_error(invoke("scan", "--listen", "0", "-i", "virtual", "-c", channel),
                          f"no device answered on virtual {channel}")


def test_one_led_command_keeps_the_other_keys(bench: Bench) -> None:
    bus, emulator, keypad, _ = bench
    run("keypad", "led", "3", "red", *bus)
    run("keypad", "led", "4", "green", *bus)
    run("keypad", "led", "5", "blue", "--blink", *bus)
    shown = emulator.snapshot(keypad)["commanded"]
    assert [shown[k - 1]["phases"] for k in (3, 4, 5)] == [
        ["red", "red"], ["green", "green"], ["blue", "off"]]


def test_restore_defaults_on_generation_1_says_so_before_asking(bench: Bench) -> None:
    bus = bench[0]
    result = invoke("keypad", "restore-defaults", *bus, answer="y\n")
    assert_one_line_error(result, "cannot restore defaults")
    assert "factory value" not in result.output  # it did not ask first
