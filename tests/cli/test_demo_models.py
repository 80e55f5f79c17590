"""``blinkcan demo --model NAME``: a short scripted scenario for every registered model (and
generation, and protocol it speaks): the host finds it, starts it, and a hand does once each
thing its face has. The default demo stays the keypad-and-Keybox controller (tests/cli)."""

from __future__ import annotations

import pytest
from click.testing import CliRunner

from blinkcan.cli.demo_model import scripted_steps
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
    lines = result.output.splitlines()
    assert f"== {description.title} at node {twin.node_id:02X}h ({protocol}) is powered on" \
        in lines
    for step in steps:
        assert f"== {step}" in lines
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
