"""A user's test sees what went wrong (issue 17 item 11): an exception raised in a key handler or
in work handed to ``host.spawn`` fails the test that caused it, with its traceback; in real time
it is logged and the loop goes on, as a controller in the field needs."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
import time
import traceback
import uuid
from pathlib import Path

import can
import pytest

from blinkcan import Keypad
from blinkcan.host import KeyEvent
from blinkcan.protocol import Frame
from blinkcan.runtime import Emulator
from blinkcan.testing import Rig
from blinkcan.twin import KeypadTwin

SRC = Path(__file__).resolve().parents[2] / "src"


def test_a_key_handler_that_raises_fails_the_rig_call_that_ran_it() -> None:
    with Rig() as rig:
        twin = rig.add(KeypadTwin(settings={"startup_led_show": 0}))
        keypad = Keypad(rig.bus, 0x15)
        seen: list[KeyEvent] = []

        def broken_handler(event: KeyEvent) -> None:
            seen.append(event)
            if event.action == "press":
                raise ZeroDivisionError("the handler's own bug")

        keypad.on_key(broken_handler)
        rig.settle()
        with pytest.raises(ZeroDivisionError, match="the handler's own bug") as raised:
            rig.press(twin, 4)
        assert [event.key for event in seen] == [4]
        assert "broken_handler" in "".join(traceback.format_tb(raised.value.__traceback__))
        rig.release(twin, 4)  # raised once: the simulation goes on
        keypad.close()


def test_work_handed_to_spawn_that_raises_fails_the_call_that_ran_it() -> None:
    with Rig() as rig:
        rig.add(KeypadTwin(settings={"startup_led_show": 0}))
        keypad = Keypad(rig.bus, 0x15)

        def broken_work() -> None:
            keypad.set_led(4, "green")
            raise KeyError("pump")

        keypad.host.spawn(broken_work)
        with pytest.raises(KeyError, match="pump") as raised:
            rig.advance(0.5)
        assert "broken_work" in "".join(traceback.format_tb(raised.value.__traceback__))
        keypad.close()


USER_TESTS = '''
from blinkcan import Keypad


def test_handler_raises(rig, keypad_twin):
    keypad = Keypad(rig.bus, 0x15)

    def on_key(event):
        raise RuntimeError("handler bug in the user's controller")

    keypad.on_key(on_key)
    rig.settle()  # the driver starts the keypad
    rig.tap(keypad_twin, 2)
    keypad.close()


def test_spawned_work_raises(rig, keypad_twin):
    keypad = Keypad(rig.bus, 0x15)
    keypad.on_key(lambda event: keypad.host.spawn(lambda: 1 / 0))
    rig.settle()
    rig.tap(keypad_twin, 2)
    rig.advance(1.0)
    keypad.close()


def test_nothing_raises(rig, keypad_twin):
    keypad = Keypad(rig.bus, 0x15)
    keypad.on_key(lambda event: None)
    rig.settle()
    rig.tap(keypad_twin, 2)
    keypad.close()
'''


def test_under_the_pytest_plugin_a_raising_handler_fails_the_users_test(tmp_path: Path) -> None:
    user = tmp_path / "test_user_controller.py"
    user.write_text(textwrap.dedent(USER_TESTS))
    result = subprocess.run(
        [sys.executable, "-m", "pytest", "-p", "no:cacheprovider", "-q", str(user)],
        check=False, cwd=tmp_path, capture_output=True, text=True, timeout=120,
        env={**os.environ, "PYTHONPATH": f"{SRC}{os.pathsep}{os.environ.get('PYTHONPATH', '')}"})
    output = result.stdout + result.stderr
    assert result.returncode == 1, output
    assert "2 failed, 1 passed" in output
    assert "RuntimeError: handler bug in the user's controller" in output
    assert "ZeroDivisionError" in output
    assert "def on_key(event):" in output  # the handler itself is in the traceback


def test_in_real_time_a_raising_handler_is_logged_and_the_loop_goes_on(
        caplog: pytest.LogCaptureFixture) -> None:
    channel = f"h17a-{uuid.uuid4()}"
    twin = KeypadTwin(settings={"startup_led_show": 0})
    device_bus = can.Bus(interface="virtual", channel=channel)
    host_bus = can.Bus(interface="virtual", channel=channel)
    seen: list[int] = []

    def on_key(event: KeyEvent) -> None:
        seen.append(event.key)
        if event.key == 1:
            raise RuntimeError("a bug in the field")

    try:
        with Emulator(device_bus, [twin]) as emulator:
            keypad = Keypad(host_bus, 0x15)
            keypad.on_key(on_key)
            emulator.run(lambda now: twin.receive(Frame(0, b"\x01\x15"), now))
            for key in (1, 2):
                emulator.press(twin, key)
                emulator.release(twin, key)
            deadline = time.monotonic() + 5
            while seen.count(2) < 1 and time.monotonic() < deadline:
                time.sleep(0.01)
            keypad.close()
    finally:
        device_bus.shutdown()
        host_bus.shutdown()
    assert 2 in seen  # the loop went on after the handler raised for key 1
    assert "a bug in the field" in caplog.text
    assert "the loop goes on" in caplog.text
