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
from blinkcan.devices.keypad_j1939 import DEFAULT_ADDRESS
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
    where = f"address {DEFAULT_ADDRESS:02X}h (J1939)" if protocol == "j1939" else \
        f"node {twin.node_id:02X}h (CANopen)"  # before: "node 15h (j1939)", not where it is
    assert f"== {description.title} at {where} is powered on" in lines
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
    (["--model", "nosuch"], "unknown device 'nosuch'"),
    (["--model", "keybox", "--protocol", "j1939"], "--protocol j1939 applies to"),
])
def test_demo_model_mistakes_are_one_line(args: list[str], message: str) -> None:
    result = CliRunner().invoke(cli, ["demo", *args, "--pause", "0"])
    assert result.exit_code == 2, result.output
    assert len(result.output.strip().splitlines()) == 1, result.output
    assert message in result.output


#: the models that speak J1939, from the registry (one today: the PKP-2600-SI)
J1939_MODELS = [m for m in models() if any("j1939" in m.description(g).features
                                           for g in m.generations)]


def test_protocol_j1939_with_no_model_runs_the_model_that_speaks_it() -> None:
    """``demo --protocol j1939`` was refused ("--protocol is for the device of --model") though
    one model only speaks J1939: the demo picks it and says so in its first line."""
    assert len(J1939_MODELS) == 1  # with several, the demo asks which (next test)
    title = J1939_MODELS[0].description().title
    result = CliRunner().invoke(cli, ["demo", "--protocol", "j1939", "--pause", "0"])
    assert result.exit_code == 0, result.output
    lines = result.output.splitlines()
    assert lines[0] == f"== --protocol j1939 with no --model: the {title}, the one model " \
        "that speaks J1939", result.output
    assert f"== {title} at address {DEFAULT_ADDRESS:02X}h (J1939) is powered on" in lines
    assert lines[-1].endswith(f"frames on the bus ({title})")


def test_protocol_j1939_with_no_model_and_several_models_asks_which(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """Were a second model to speak J1939, the demo could not pick: one line naming them."""
    from blinkcan.cli import demo

    keybox = next(m for m in models() if m.name == "keybox")
    monkeypatch.setattr(demo, "models_speaking", lambda protocol: [*J1939_MODELS, keybox])
    result = CliRunner().invoke(cli, ["demo", "--protocol", "j1939", "--pause", "0"])
    assert result.exit_code == 2, result.output
    assert len(result.output.strip().splitlines()) == 1, result.output
    names = ", ".join(m.name for m in [*J1939_MODELS, keybox])
    assert f"--protocol j1939 needs --model: {names} speak it" in result.output


def _section(lines: list[str], title: str) -> list[str]:
    """The lines after the step titled ``title``, up to the next title."""
    after = lines[lines.index(title) + 1:]
    return after[:next((n for n, line in enumerate(after) if line.startswith("==")),
                       len(after))]


@pytest.mark.parametrize(("spec", "protocol"), CASES)
def test_a_step_whose_effect_comes_later_shows_it(spec: str, protocol: str) -> None:
    """A new fuse sends nothing (a latched FAULT stays until RESET, 2001h value 02h: Keybox
    errata K12), so the host then resets the output and the frame shows; a voltage on an
    analog input shows in the next periodic analog PDO, which the step waits for. With
    ``--pause 0`` both steps showed no frame at all."""
    result = CliRunner().invoke(cli, ["demo", "--model", spec, "--protocol", protocol,
                                      "--pause", "0"])
    assert result.exit_code == 0, result.output
    twin = build_twin(spec)
    try:
        steps = {action.name: (title, values) for title, action, values in scripted_steps(twin)}
    finally:
        twin.close()
    lines = result.output.splitlines()
    if "replace_fuse" in steps:
        title, values = steps["replace_fuse"]
        after = lines[lines.index(f"== {title}") + 1:]
        reset = f"== the host resets output {values['pin']}"
        assert any(line.startswith(reset) for line in after), result.output
        shown = _section(after, next(line for line in after if line.startswith(reset)))
        assert any(" > " in line and "2001h" in line for line in shown), result.output
    if "set_analog" in steps:
        title, values = steps["set_analog"]
        shown = _section(lines, f"== {title}")
        volts = f"in{values['input']} {values['volts']:g} V"
        assert any(" < " in line and volts in line for line in shown), (volts, result.output)
    if protocol == "j1939":  # before: nothing after the power-on (the keypad says nothing: §5,
        # heartbeat and claim off): the host now turns its heartbeat on, the counter back at 00h
        # is a power-on
        title, _ = steps["power_on"]
        after = lines[lines.index(f"== {title}"):]
        assert any(" < " in line and "heartbeat 0," in line for line in after), result.output
        restored = _section(after, "== the driver hears the power-on (its heartbeat counter "
                                   "back at 00h) and shows the LEDs again")
        assert any(" > " in line and "LED 1 green" in line for line in restored), result.output
