"""A bad ``@pytest.mark.blinkcan`` fails its test whatever fixtures the test uses (found by the
attack pass of session 5: ``model="nope"`` was only checked when the test took
``keypad_twin``, so a test taking ``rig`` alone, or no fixture, passed with it). Run as a
user's test file under pytest, in a subprocess, as the plugin's users run it."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import blinkcan

SRC = Path(blinkcan.__file__).resolve().parent.parent

USER_TESTS = '''
import pytest


@pytest.mark.blinkcan(model="nope")
def test_model_no_fixture():
    pass


@pytest.mark.blinkcan(model="nope")
def test_model_rig_only(rig):
    pass


@pytest.mark.blinkcan(model="nope")
def test_model_keybox_twin(keybox_twin):
    pass


@pytest.mark.blinkcan(model="keybox")
def test_model_not_a_keypad():
    pass


@pytest.mark.blinkcan(manual="9.9")
def test_manual():
    pass


@pytest.mark.blinkcan(model="pkp-3500-mt", protocol="j1939")
def test_protocol():
    pass


@pytest.mark.blinkcan(keybox_node=0x99)
def test_node(rig):
    pass


@pytest.mark.blinkcan(quirks="nope")
def test_quirks():
    pass


@pytest.mark.blinkcan(startup_show="yes")
def test_startup_show():
    pass


@pytest.mark.blinkcan(modle="pkp-3500-mt")
def test_option_unknown():
    pass


@pytest.mark.blinkcan("pkp-3500-mt")
def test_positional():
    pass


@pytest.mark.blinkcan(model="pkp-3500-mt", keypad_node=0x16)
def test_good_marker(rig):
    pass


def test_no_marker(rig):
    pass
'''

#: each bad marker's test, and what its one line says
SAID = {
    "test_model_no_fixture": "unknown device 'nope'; known: pkp-2600-si",
    "test_model_rig_only": "unknown device 'nope'",
    "test_model_keybox_twin": "unknown device 'nope'",
    "test_model_not_a_keypad": "'keybox' is not a keypad",
    "test_manual": "manual must be one of 1.1, 1.5, not '9.9'",
    "test_protocol": "has no documented J1939 mode",
    "test_node": "node id 0x99 outside 0x01..0x7f",
    "test_quirks": "quirks must be one of firmware, cia301",
    "test_startup_show": "startup_show is True or False, not 'yes'",
    "test_option_unknown": "does not take modle: it takes model, manual",
    "test_positional": "takes names only",
}


def test_a_bad_marker_fails_its_test_whatever_fixtures_it_uses(tmp_path: Path) -> None:
    user = tmp_path / "test_user_markers.py"
    user.write_text(textwrap.dedent(USER_TESTS))
    result = subprocess.run(
        [sys.executable, "-m", "pytest", "-p", "no:cacheprovider", "-rE", str(user)],
        check=False, cwd=tmp_path, capture_output=True, text=True, timeout=120,
        env={**os.environ, "PYTHONPATH": f"{SRC}{os.pathsep}{os.environ.get('PYTHONPATH', '')}"})
    output = result.stdout + result.stderr
    assert result.returncode == 1, output
    assert f"2 passed, {len(SAID)} error" in output, output
    for test in SAID:
        lines = [line for line in output.splitlines()
                 if line.startswith(f"ERROR test_user_markers.py::{test} ")]
        assert lines, f"{test} did not fail: {output}"
    errors = output.split("= ERRORS =")[1]
    for said in SAID.values():
        assert said in errors, (said, errors)
    said_lines = [line for line in errors.splitlines()
                  if line.startswith("@pytest.mark.blinkcan: ")]
    assert len(said_lines) == len(SAID), errors
    assert "Traceback" not in errors  # one line each, the marker's mistake
