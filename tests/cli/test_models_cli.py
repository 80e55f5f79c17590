"""The PKP-3500-MT from the command line (issue 20 items 8, 9): the CLI reads the model from the
device (100Bh) and drives it with the registry's driver; ``--model`` picks one by hand; its
rings, encoders and inputs have commands; help texts and banners list the registry's models."""

from __future__ import annotations

import uuid
from collections.abc import Iterator

import can
import pytest
from click.testing import CliRunner, Result

from blinkcan.cli.emulate import _name, build_twins
from blinkcan.cli.main import cli
from blinkcan.devices.registry import models
from blinkcan.protocol import Frame
from blinkcan.runtime import Emulator
from blinkcan.twin import KeypadTwin

Bench = tuple[list[str], Emulator, KeypadTwin, KeypadTwin]


def _quiet(twin: KeypadTwin) -> KeypadTwin:
    twin.power_on(0.0)  # no start-up LED show: the LEDs show what was commanded
    twin.receive(Frame(0x600 + twin.node_id, bytes.fromhex("2F14200000000000")), 0.0)
    twin.power_off()
    return twin


@pytest.fixture
def bench() -> Iterator[Bench]:
    channel = f"cli-models-{uuid.uuid4().hex}"
    bus = can.Bus(interface="virtual", channel=channel)
    mt = _quiet(KeypadTwin(node_id=0x15, model="pkp-3500-mt"))
    si = _quiet(KeypadTwin(node_id=0x16))
    with Emulator(bus, [mt, si]) as emulator:
        yield ["-i", "virtual", "-c", channel], emulator, mt, si
    bus.shutdown()


def invoke(*args: str) -> Result:
    return CliRunner().invoke(cli, list(args), env={"COLUMNS": "200"})


def run(*args: str) -> str:
    result = invoke(*args)
    assert result.exit_code == 0, result.output
    return result.output


def test_keypad_info_and_led_drive_the_model_the_device_names(bench: Bench) -> None:
    bus, emulator, mt, _ = bench
    info = run("keypad", "info", *bus)
    assert "model             pkp-3500-mt" in info
    assert run("keypad", "led", "3", "red", *bus).strip() == "keypad 15h: key 3 red"
    assert emulator.snapshot(mt)["keys"][2]["colour"] == "red"
    assert "model             pkp-2600-si" in run("keypad", "--node-id", "0x16", "info", *bus)


def test_model_picks_the_driver_by_hand(bench: Bench) -> None:
    bus, *_ = bench
    assert "pkp-3500-mt" in run("keypad", "--model", "pkp-3500-mt", "info", *bus)
    wrong = invoke("keypad", "--model", "pkp-2600-si", "info", *bus)
    assert wrong.exit_code == 1
    assert "is a PKP-3500-MT keypad, not a PKP-2600-SI keypad" in wrong.output


def test_rings_encoders_inputs_and_objects_by_name(bench: Bench) -> None:
    bus, emulator, mt, _ = bench
    assert run("keypad", "ring", "1", "1,2,16", *bus).strip() == "keypad 15h: ring 1 LEDs 1, 2, 16"
    assert run("keypad", "ring", "2", "17", *bus).strip() == "keypad 15h: ring 2 LEDs 17"
    assert emulator.run(lambda now: mt.objects["led_on_rings"]) == 0x0001_8003
    emulator.run(lambda now: mt.turn(2, 3, now))  # type: ignore[attr-defined]
    assert run("keypad", "encoder", "2", *bus).strip() == "encoder 2: counter 3, top 8"
    assert run("keypad", "encoder", "1", "--top", "10", *bus).strip() == (
        "encoder 1: counter 0, top 10")
    emulator.run(lambda now: mt.set_analog(2, 3.0, now))  # type: ignore[attr-defined]
    lines = run("keypad", "inputs", *bus).splitlines()
    assert lines[2] == "IN2: 3.00 V, digital high"
    assert len(lines) == 4
    assert "encoder_1_top (2000h/" in run("keypad", "read", "encoder_1_top", *bus)
    assert run("keypad", "write", "analog_period", "50", *bus).strip().endswith("= 50")
    assert emulator.run(lambda now: mt.objects["analog_period"]) == 50


def test_a_model_without_rings_says_so_in_one_line(bench: Bench) -> None:
    bus, *_ = bench
    result = invoke("keypad", "--node-id", "0x16", "ring", "1", "1", *bus)
    assert result.exit_code == 1
    assert "no encoder rings (the PKP-2600-SI keypad at node 16h)" in result.output
    unknown = invoke("keypad", "read", "no_such_object", *bus)
    assert "no object 'no_such_object' (any registered keypad)" in unknown.output


def test_help_and_banners_list_the_registry() -> None:
    for command in (["export", "-h"], ["emulate", "-h"]):
        text = " ".join(run(*command).split())
        assert "keypad|keybox" not in text
        for found in models():
            assert found.name in text
    for found in models():
        twin = build_twins((found.name,), None, None, "firmware")[0]
        assert _name(twin).startswith(f"{found.description().title} {twin.node_id:02X}h")
