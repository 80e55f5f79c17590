"""Ctrl-C is how a user stops a command: exit 130 or 0, never an "Error" (issue 20 item 14)."""

from __future__ import annotations

import signal
import subprocess
import sys
import time


def test_ctrl_c_on_the_demo_is_no_error() -> None:
    demo = subprocess.Popen([sys.executable, "-m", "blinkcan", "demo", "--pause", "0.5"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    try:
        time.sleep(3.0)  # into the scripted steps (the venv's imports take about a second)
        demo.send_signal(signal.SIGINT)
        _, errors = demo.communicate(timeout=20)
    finally:
        demo.kill()
    assert demo.returncode in (0, 130), errors
    assert "Error" not in errors
