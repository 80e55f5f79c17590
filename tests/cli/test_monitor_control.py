"""monitor, and the one-shot keypad / keybox commands, against twins on a virtual bus."""

from __future__ import annotations

import threading
import time
import uuid
from collections.abc import Iterator
from pathlib import Path

import can
import pytest
from click.testing import CliRunner

from blinkcan.cli.main import cli
from blinkcan.formats.logs import FrameWriter
from blinkcan.protocol import Frame
from blinkcan.runtime import Emulator, to_message
from blinkcan.twin import KeyboxTwin, KeypadTwin
from tests.cli.session import session
from tests.host.conftest import quiet_keypad


@pytest.fixture
def bench() -> Iterator[tuple[str, Emulator, KeypadTwin, KeyboxTwin]]:
    channel = f"cli-{uuid.uuid4().hex}"
    bus = can.Bus(interface="virtual", channel=channel)
    keypad, keybox = quiet_keypad(), KeyboxTwin()
    with Emulator(bus, [keypad, keybox]) as emulator:
        yield channel, emulator, keypad, keybox
    bus.shutdown()


def run(*args: str) -> str:
    # monitor's picture as a terminal shows it (rich: TTY_COMPATIBLE); a pipe gets lines
    result = CliRunner().invoke(cli, list(args),
                                env={"COLUMNS": "160", "TTY_COMPATIBLE": "1", "NO_COLOR": "1"})
    assert result.exit_code == 0, result.output
    return result.output


def test_monitor_replays_a_log_into_the_device_views(tmp_path: Path) -> None:
    path = tmp_path / "session.log"
    with FrameWriter(path) as writer:
        for timestamp, frame in session():
            writer.write(timestamp, frame)
    output = run("monitor", "--file", str(path))
    assert "keypad 15h" in output
    assert "[ 2 red" in output  # LEDs on: red 2, 7; green 5
    assert "[ 5 green" in output
    assert "outputs in FAULT: 4" in output
    assert "4:OFF" in output  # the session RESETs it after the fault
    assert "keybox 0Ch, operational" in output  # the broadcast NMT start
    assert "SDO abort 1017h/00" in output


def test_monitor_follows_a_live_bus(bench: tuple[str, Emulator, KeypadTwin, KeyboxTwin]) -> None:
    channel, emulator, keypad, _ = bench
    host = can.Bus(interface="virtual", channel=channel)

    def traffic() -> None:
        time.sleep(0.2)
        host.send(to_message(Frame(0, b"\x01\x00")))
        time.sleep(0.05)
        host.send(to_message(Frame(0x215, bytes.fromhex("0000000100000000"))))  # blue 1
        emulator.press(keypad, 6)

    sender = threading.Thread(target=traffic)
    sender.start()
    output = run("monitor", "--duration", "0.6", "--device", "0x15=keypad", "-i", "virtual",
                 "-c", channel)
    sender.join()
    host.shutdown()
    assert "[ 1 blue" in output
    assert "key 6 pressed" in output


def test_keypad_commands(bench: tuple[str, Emulator, KeypadTwin, KeyboxTwin]) -> None:
    channel, emulator, keypad, _ = bench
    bus = ["-i", "virtual", "-c", channel]
    assert "software_version  V2.2" in run("keypad", *bus, "info")
    run("keypad", *bus, "led", "3", "red", "--blink", "green")
    run("keypad", *bus, "backlight", "--colour", "cyan", "--level", "20")
    run("keypad", *bus, "brightness", "40")
    snapshot = emulator.snapshot(keypad)
    assert snapshot["keys"][2]["phases"] == ["red", "green"]
    assert snapshot["backlight"] == {"colour": "cyan", "level": 20}
    assert snapshot["indicator_brightness"] == 40
    run("keypad", *bus, "heartbeat", "200")
    run("keypad", *bus, "set-node-id", "0x22", "--yes")
    assert emulator.snapshot(keypad)["settings"]["node_id"] == 0x22


def test_keybox_commands(bench: tuple[str, Emulator, KeypadTwin, KeyboxTwin]) -> None:
    channel, emulator, _, keybox = bench
    bus = ["-i", "virtual", "-c", channel]
    run("keybox", *bus, "on", "5")
    emulator.run(lambda now: keybox.blow_fuse(5, now))
    assert run("keybox", *bus, "faults").strip() == "5"
    assert "pin  5: fault" in run("keybox", *bus, "states")
    run("keybox", *bus, "reset", "5")
    assert run("keybox", *bus, "faults").strip() == "no output in FAULT"
    run("keybox", *bus, "set-baud", "250000", "--yes")
    assert emulator.snapshot(keybox)["settings"]["baud_rate"] == 1


@pytest.mark.parametrize(("args", "message"), [
    (["keybox", "on", "14"], "pin 14 outside 1..13"),
    (["keypad", "led", "1", "purple"], "unknown LED colour 'purple'"),
    (["keypad", "set-baud", "300000", "--yes"], "bit rate 300000 bit/s is not one of 20000,"),
])
def test_control_mistakes_are_one_clear_line(
        bench: tuple[str, Emulator, KeypadTwin, KeyboxTwin], args: list[str],
        message: str) -> None:
    channel = bench[0]
    result = CliRunner().invoke(cli, [args[0], "-i", "virtual", "-c", channel, *args[1:]])
    assert result.exit_code != 0
    assert message in result.output
    assert "Traceback" not in result.output


def test_a_device_that_does_not_answer_is_one_clear_line() -> None:
    result = CliRunner().invoke(cli, ["keypad", "-i", "virtual", "-c",
                                      f"empty-{uuid.uuid4().hex}", "info"])
    assert result.exit_code != 0
    assert "no reply within" in result.output


def test_set_node_id_asks_first(bench: tuple[str, Emulator, KeypadTwin, KeyboxTwin]) -> None:
    channel, emulator, keypad, _ = bench
    result = CliRunner().invoke(cli, ["keypad", "-i", "virtual", "-c", channel, "set-node-id",
                                      "0x30"], input="n\n")
    assert result.exit_code == 0  # "n" is an answer, not an error (issue 20 item 14)
    assert result.output.splitlines()[-1].endswith(": nothing changed")
    assert emulator.snapshot(keypad)["settings"]["node_id"] == 0x15
