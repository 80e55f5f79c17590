"""One name for a model wherever the command line shows it: the registered model, as its
description names it (what ``--model`` takes), over CANopen and J1939 alike. Found by the
attack pass of session 5: ``scan`` left the model of a J1939 keypad blank, and ``keypad
info`` said "pkp-2600-si" over CANopen but "PKP-2600-SI keypad" over J1939."""

from __future__ import annotations

import pytest
from click.testing import CliRunner, Result

from blinkcan.cli.main import cli
from blinkcan.devices.registry import models
from blinkcan.runtime.simbus import SimulatedBus
from blinkcan.testing import Rig
from blinkcan.twin import KeypadTwin

J1939_MODELS = [pytest.param(m.name, g, id=f"{m.name}@{g}") for m in models()
                for g in m.generations if "j1939" in m.description(g).features]


def _run(rig: Rig, monkeypatch: pytest.MonkeyPatch, *args: str) -> Result:
    """The command line on the rig's simulated bus (its waits in virtual time)."""
    for module in ("blinkcan.cli.scan", "blinkcan.cli.control"):
        monkeypatch.setattr(f"{module}.cli_bus", lambda: SimulatedBus(rig.network, "cli"))
    result = CliRunner().invoke(cli, list(args), env={"COLUMNS": "200"})
    assert result.exit_code == 0, result.output
    return result


def _model_line(output: str) -> str:
    return next(line for line in output.splitlines() if line.startswith("model "))


@pytest.mark.parametrize(("model", "generation"), J1939_MODELS)
def test_scan_names_the_model_of_a_j1939_keypad_as_of_a_canopen_one(
        monkeypatch: pytest.MonkeyPatch, model: str, generation: str) -> None:
    with Rig() as rig:
        rig.add(KeypadTwin(model=model, manual=generation, node_id=0x15))
        rig.add(KeypadTwin(model=model, manual=generation, protocol="j1939"))  # at 21h
        rig.settle()
        output = _run(rig, monkeypatch, "scan", "--listen", "0.05").output
    canopen = next(line for line in output.splitlines() if "15h" in line)
    j1939 = next(line for line in output.splitlines() if "J1939" in line)
    assert f" {model} " in canopen, output
    assert f" {model} " in j1939, output  # was blank


@pytest.mark.parametrize(("model", "generation"), J1939_MODELS)
def test_keypad_info_names_the_model_alike_over_canopen_and_j1939(
        monkeypatch: pytest.MonkeyPatch, model: str, generation: str) -> None:
    with Rig() as rig:
        rig.add(KeypadTwin(model=model, manual=generation, node_id=0x15))
        rig.add(KeypadTwin(model=model, manual=generation, protocol="j1939"))
        rig.settle()
        canopen = _model_line(_run(rig, monkeypatch, "keypad", "info").output)
        j1939 = _model_line(_run(rig, monkeypatch, "keypad", "--protocol", "j1939",
                                 "info").output)
    assert canopen.split() == ["model", model]
    assert j1939.split() == ["model", model]  # was "PKP-2600-SI keypad"
