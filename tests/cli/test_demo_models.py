"""``blinkcan demo --model NAME``: a short scripted scenario for every registered model (and
generation, and protocol it speaks): the host finds it, starts it, shows what the model shows
(LEDs, ring LEDs, outputs on and PWM), and a hand does once each thing its face has; a fuse
blows on an output that is on, so the fault shows. The default demo stays the keypad-and-Keybox
controller (tests/cli)."""

from __future__ import annotations

from unittest import mock

import pytest
from click.testing import CliRunner

from blinkcan.cli.demo_model import host_steps, scripted_steps
from blinkcan.cli.main import cli
from blinkcan.devices.registry import models
from blinkcan.twin.registry import build_twin

#: every registered model at every generation, in every protocol it speaks
CASES = [(f"{found.name}@{generation}", protocol)
         for found in models() for generation in found.generations
         for protocol in ["canopen", *sorted({"j1939"} & found.description(generation).features)]]


@pytest.mark.parametrize(("spec", "protocol"), CASES)
def test_the_demo_of_each_model_runs_its_scenario(spec: str, protocol: str) -> None:
    result = CliRunner().invoke(cli, ["demo", "--model", spec, "--protocol", protocol,
                                      "--pause", "0"])
    assert result.exit_code == 0, result.output
    twin = build_twin(spec)
    try:
        description = twin.description
        steps = [title for title, _, _ in scripted_steps(twin)]
    finally:
        twin.close()
    face = description.face
    commands = [title for title, _ in host_steps(mock.Mock(), face)]
    lines = result.output.splitlines()
    assert f"== {description.title} at node {twin.node_id:02X}h ({protocol}) is powered on" \
        in lines
    for step in steps:
        assert f"== {step}" in lines
    # what the model shows: each command of the host, and a frame the host sent for it
    assert bool(commands) == bool(face.led_keys or face.pins), commands
    for command in commands:
        after = lines[lines.index(f"== {command}") + 1:]
        shown = after[:next((n for n, line in enumerate(after) if line.startswith("==")),
                            len(after))]
        assert any(" > " in line for line in shown), (command, result.output)
    if face.led_keys:
        assert any(f"the host lights key {face.led_keys[0]}'s LED" in c for c in commands)
    if face.pins:
        assert f"the host switches output {face.pin_numbers[0]} on" in commands
        assert any(line.endswith(f"outputs in FAULT: {face.pin_numbers[0]}")
                   for line in lines), result.output  # the fuse blew on an output that is on
    assert any(step.startswith("press a key") for step in steps) == \
        any("key 1 pressed" in line for line in lines)
    if protocol == "canopen":
        model_id = description.table["model_id"].default
        assert any(line.startswith(f"   found: {model_id} ") for line in lines), result.output
        assert sum(line.endswith(": boot-up") for line in lines) == 2  # on, and on again
    else:
        assert any("software revision" in line for line in lines), result.output
    assert lines[-1].endswith(f"frames on the bus ({description.title})")


@pytest.mark.parametrize(("args", "message"), [
    (["--protocol", "j1939"], "--protocol is for the device of --model"),
    (["--model", "nosuch"], "unknown device 'nosuch'"),
    (["--model", "keybox", "--protocol", "j1939"], "--protocol j1939 applies to"),
])
def test_demo_model_mistakes_are_one_line(args: list[str], message: str) -> None:
    result = CliRunner().invoke(cli, ["demo", *args, "--pause", "0"])
    assert result.exit_code == 2, result.output
    assert len(result.output.strip().splitlines()) == 1, result.output
    assert message in result.output
