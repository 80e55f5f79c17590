"""A user's test on the ``rig`` fixture fails, never hangs, when it waits in real time for what
only the simulation brings (found by the attack pass of session 7: an ``asyncio.Event`` set by
an ``on_key`` callback, a ``threading.Event`` the same, ``time.sleep`` in a handler, a thread
of its own joined: each hung pytest for ever, since nothing ran the simulation). Run as a
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
import asyncio
import threading
import time

from blinkcan import Keypad
from blinkcan.host import AsyncKeypad


def test_awaits_an_asyncio_event(rig, keypad_twin):
    async def main():
        keypad = await AsyncKeypad(rig.bus, 0x15).open()
        pressed = asyncio.Event()
        loop = asyncio.get_running_loop()
        keypad.on_key(lambda event: loop.call_soon_threadsafe(pressed.set))
        await pressed.wait()  # nobody presses, and nothing runs the simulation

    asyncio.run(main())


def test_waits_for_a_threading_event(rig, keypad_twin):
    keypad = Keypad(rig.bus, 0x15)
    pressed = threading.Event()
    keypad.on_key(lambda event: pressed.set())
    pressed.wait()


def test_sleeps_in_a_handler(rig, keypad_twin):
    keypad = Keypad(rig.bus, 0x15)
    keypad.on_key(lambda event: time.sleep(3600))
    rig.tap(keypad_twin, 3)


def test_joins_a_thread_of_its_own(rig):
    worker = threading.Thread(target=threading.Event().wait, daemon=True)
    worker.start()
    worker.join()


def test_that_finishes(rig, keypad_twin):
    Keypad(rig.bus, 0x15).set_led(1, "red")
    rig.advance(600)
'''

HANGING = ("test_awaits_an_asyncio_event", "test_waits_for_a_threading_event",
           "test_sleeps_in_a_handler", "test_joins_a_thread_of_its_own")


def _pytest(tmp_path: Path, *options: str) -> subprocess.CompletedProcess[str]:
    user = tmp_path / "test_user_waits.py"
    user.write_text(textwrap.dedent(USER_TESTS))
    return subprocess.run(
        [sys.executable, "-m", "pytest", "-p", "no:cacheprovider", "-q", str(user), *options],
        check=False, cwd=tmp_path, capture_output=True, text=True, timeout=240,
        env={**os.environ, "COLUMNS": "300",
             "PYTHONPATH": f"{SRC}{os.pathsep}{os.environ.get('PYTHONPATH', '')}"})


def test_a_test_waiting_in_real_time_fails_with_what_it_waits_for(tmp_path: Path) -> None:
    result = _pytest(tmp_path, "--blinkcan-wall-limit", "2")
    output = result.stdout + result.stderr
    assert result.returncode == 1, output
    assert f"{len(HANGING)} failed, 1 passed" in output, output
    for test in HANGING:
        assert f"FAILED test_user_waits.py::{test} - Failed: blinkcan:" in output, (test, output)
    assert output.count("still ran after 2 s of wall time, at virtual t=") >= len(HANGING)
    assert "waits in real time for what only the simulation brings" in output


def test_the_ini_option_sets_the_limit_and_a_wrong_one_is_a_usage_error(
        tmp_path: Path) -> None:
    result = _pytest(tmp_path, "-o", "blinkcan_wall_limit=1.5", "-k", "joins or finishes")
    output = result.stdout + result.stderr
    assert "1 failed, 1 passed" in output, output
    assert "still ran after 1.5 s of wall time" in output, output
    for wrong in (("--blinkcan-wall-limit", "nan"), ("-o", "blinkcan_wall_limit=soon")):
        result = _pytest(tmp_path, *wrong)
        output = result.stdout + result.stderr
        assert result.returncode == 4, output  # pytest's usage error
        assert "blinkcan_wall_limit: seconds >= 0 (0: no limit)" in output, output
