"""dev.py, the README's first commands: Ctrl-C on `python3 dev.py demo` (found by the last
newcomer pass: dev.py printed a KeyboardInterrupt traceback and killed the demo)."""

from __future__ import annotations

import signal
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


@pytest.mark.skipif(not (ROOT / ".venv" / ".blinkcan-installed").exists(),
                    reason="dev.py runs the tools in ROOT/.venv (made by `python3 dev.py test`)")
def test_ctrl_c_on_dev_py_demo_is_the_demos_answer_not_a_traceback() -> None:
    dev = subprocess.Popen([sys.executable, str(ROOT / "dev.py"), "demo", "--pause", "0.5"],
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert dev.stdout is not None
        for _ in range(40):  # the demo is running: its frames are printed
            if "SDO" in dev.stdout.readline():
                break
        dev.send_signal(signal.SIGINT)  # dev.py alone, as `timeout -s INT` does
        _, errors = dev.communicate(timeout=30)
    finally:
        dev.kill()
    assert "Traceback" not in errors, errors
    assert "interrupted" in errors
