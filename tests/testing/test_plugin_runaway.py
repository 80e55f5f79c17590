"""A user's test whose simulation runs on for ever (a ``while`` around ``rig.advance`` whose
condition never comes true) fails after the wall limit saying so, not that "nothing runs the
simulation meanwhile" (what the limit said for every hang: hatk10 met it with a Keybox
``fault_poll`` on a powered-off Keybox, virtual time past 138,000 s). Run as a user's test
file under pytest, in a subprocess, as the plugin's users run it."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import blinkcan

SRC = Path(blinkcan.__file__).resolve().parent.parent

USER_TESTS = '''
import threading

from blinkcan import Keypad


def test_advances_until_a_key_nobody_presses(rig, keypad_twin):
    keypad = Keypad(rig.bus, 0x15)
    pressed = []
    keypad.on_key(pressed.append)
    while not pressed:
        rig.advance(0.5)


def test_waits_for_a_threading_event(rig, keypad_twin):
    keypad = Keypad(rig.bus, 0x15)
    pressed = threading.Event()
    keypad.on_key(lambda event: pressed.set())
    pressed.wait()
'''


def test_a_simulation_that_runs_on_is_told_from_one_that_waits(tmp_path: Path) -> None:
    user = tmp_path / "test_user_runaway.py"
    user.write_text(textwrap.dedent(USER_TESTS))
    result = subprocess.run(
        [sys.executable, "-m", "pytest", "-p", "no:cacheprovider", "-q", str(user),
         "--blinkcan-wall-limit", "2"],
        check=False, cwd=tmp_path, capture_output=True, text=True, timeout=240,
        env={**os.environ, "COLUMNS": "400",
             "PYTHONPATH": f"{SRC}{os.pathsep}{os.environ.get('PYTHONPATH', '')}"})
    output = result.stdout + result.stderr
    assert "2 failed" in output, output
    runaway = next(line for line in output.splitlines()
                   if "test_advances_until_a_key_nobody_presses - Failed" in line)
    assert "the simulation ran on" in runaway, runaway
    assert "nothing runs the simulation" not in runaway, runaway
    waiting = next(line for line in output.splitlines()
                   if "test_waits_for_a_threading_event - Failed" in line)
    assert "nothing runs the simulation meanwhile" in waiting, waiting
