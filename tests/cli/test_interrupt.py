"""Ctrl-C is how a user stops a command: exit 130 or 0, never an "Error" (issue 20 item 14)."""

from __future__ import annotations

import re
import signal
import subprocess
import sys
import time
import uuid
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def test_ctrl_c_on_the_demo_is_no_error() -> None:
    demo = subprocess.Popen([sys.executable, "-m", "blinkcan", "demo", "--pause", "0.5"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert demo.stdout is not None
        for _ in range(40):  # into the scripted steps: its frames are printed (a fixed sleep
            if "SDO" in demo.stdout.readline():  # was too short under load: SIGINT came
                break  # before Python's own handler, exit -2)
        demo.send_signal(signal.SIGINT)
        _, errors = demo.communicate(timeout=20)
    finally:
        demo.kill()
    assert demo.returncode in (0, 130), errors
    assert "Error" not in errors


#: a child's first lines: "started" on stderr when ``blinkcan.cli.main`` (the command line:
#: click, rich, python-can after it) starts being imported. What runs before an entry point's
#: code (the interpreter's start-up, site, runpy finding blinkcan) no entry point can reach.
_SAY_STARTED = """import sys
class SayStarted:
    def find_spec(self, name, path=None, target=None):
        if name == "blinkcan.cli.main":
            sys.stderr.write("started\\n")
            sys.stderr.flush()
            sys.meta_path.remove(self)
sys.meta_path.insert(0, SayStarted())
"""


def _started(code: str, args: list[str]) -> str:
    """A child that runs ``code`` (the entry point's own lines) with ``args``."""
    return f"{_SAY_STARTED}sys.argv[:] = ['blinkcan', *{args!r}]\n{code}"


def _console_script() -> str:
    """What the ``blinkcan`` script pip writes runs: ``from M import F; sys.exit(F())``."""
    script = re.search(r'^blinkcan = "(.+?):(.+?)"$', (ROOT / "pyproject.toml").read_text(),
                       re.MULTILINE)
    assert script is not None
    module, function = script.groups()
    return f"from {module} import {function}\nsys.exit({function}())"


@pytest.mark.parametrize("entry", ["script", "module"])
def test_ctrl_c_while_the_command_line_loads_is_one_line(entry: str) -> None:
    """Ctrl-C during the imports (the first few tenths of a second) printed a traceback of
    whatever import it hit. Delays from nothing to past the imports: never a traceback, only
    "interrupted" (exit 130), or the command's own clean stop."""
    code = _console_script() if entry == "script" else \
        "import runpy\nrunpy.run_module('blinkcan', run_name='__main__', alter_sys=True)"
    args = ["scan", "-i", "virtual", "-c", f"start-{uuid.uuid4().hex}", "--listen", "5"]
    for delay in (0.0, 0.002, 0.01, 0.02, 0.04, 0.08, 0.16, 0.3):
        child = subprocess.Popen([sys.executable, "-c", _started(code, args)],
                                 stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        try:
            assert child.stderr is not None
            assert child.stderr.readline() == "started\n"
            time.sleep(delay)
            child.send_signal(signal.SIGINT)
            _, errors = child.communicate(timeout=30)
        finally:
            child.kill()
        assert "Traceback" not in errors, (delay, errors)
        assert child.returncode == 130, (delay, errors)
        assert errors.strip().splitlines()[-1:] == ["interrupted"], (delay, errors)


#: a Ctrl-C that lands while an import frees its module lock: the interpreter runs that lock's
#: weak-reference callback (``_get_module_lock.<locals>.cb``), where an exception is "ignored"
#: (printed with a traceback, then dropped). A trace hook sends the SIGINT there, every time.
_CTRL_C_IN_AN_IMPORT_LOCK = """
import os, signal, sys
from blinkcan.cli import entry
entry.keep_interrupts_from_callbacks()
def trace(frame, event, arg):
    if event == "call" and frame.f_code.co_name == "cb" and "importlib" in frame.f_code.co_filename:
        sys.settrace(None)
        os.kill(os.getpid(), signal.SIGINT)
sys.settrace(trace)
try:
    import json.tool  # a first import: its module lock is made, then freed
    sys.settrace(None)
    import time
    deadline = time.monotonic() + 30  # the Ctrl-C comes back at once; a loaded machine is slow
    while time.monotonic() < deadline: pass
    print("not interrupted")
except KeyboardInterrupt:
    print("interrupted")
"""


def test_ctrl_c_in_an_import_locks_callback_still_stops_the_command() -> None:
    """Ctrl-C while a command's first lazy import finishes (the first tenths of a second of
    any command; ``test_ctrl_c_while_the_command_line_loads_is_one_line`` hit it once under
    load) landed in importlib's lock callback: "Exception ignored in ... cb", a traceback, and
    the Ctrl-C was lost (the command ran on). It is raised again where the command catches it."""
    done = subprocess.run([sys.executable, "-c", _CTRL_C_IN_AN_IMPORT_LOCK], capture_output=True,
                          text=True, timeout=60, check=False)
    assert (done.stdout, done.stderr) == ("interrupted\n", "")
