"""The README's driver programs run as written, with a virtual bus in place of can0, against a
keypad (15h) and a Keybox (0Ch) twin; the test plays the user (presses keys, blows a fuse) and
ends a program that loops forever by closing its drivers, as a shutdown would."""

from __future__ import annotations

import re
import threading
import uuid
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import can
import pytest

from blinkcan.host.device import Device
from blinkcan.runtime import Emulator
from blinkcan.twin import KeyboxTwin, KeypadTwin
from tests.host.conftest import quiet_keypad, wait_until

README = Path(__file__).resolve().parents[2] / "README.md"
CAN0 = 'can.Bus(interface="socketcan", channel="can0")'


class Program:
    """A README program running in a thread of its own, as an application's main thread."""

    def __init__(self, title: str, channel: str) -> None:
        section = README.read_text().split(f"## {title}\n", 1)[1]
        code = re.search(r"```python\n(.*?)```", section, re.S)
        assert code is not None, f"no program under {title}"
        assert CAN0 in code.group(1), f"no program on can0 under {title}"
        virtual = f'can.Bus(interface="virtual", channel="{channel}")'
        self.code = code.group(1).replace(CAN0, virtual)
        self.names: dict[str, Any] = {}
        self.error: BaseException | None = None
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        try:
            exec(compile(self.code, "README.md", "exec"), self.names)
        except BaseException as error:  # reported by stop()
            self.error = error

    def finished(self) -> bool:
        return not self._thread.is_alive()

    def has(self, *names: str) -> bool:
        return all(name in self.names for name in names)

    def stop(self) -> None:
        """Close the program's drivers (its event loops end), then its bus."""
        for value in list(self.names.values()):
            if isinstance(value, Device):
                value.close()
        self._thread.join(timeout=5)
        assert not self._thread.is_alive(), "the program did not end when its drivers closed"
        bus = self.names.get("bus")
        if isinstance(bus, can.BusABC):
            bus.shutdown()
        if self.error is not None:
            raise self.error


@pytest.fixture
def bench() -> Iterator[tuple[str, Emulator, KeypadTwin, KeyboxTwin]]:
    channel = f"readme-{uuid.uuid4().hex}"
    bus = can.Bus(interface="virtual", channel=channel)
    keypad, keybox = quiet_keypad(), KeyboxTwin()
    with Emulator(bus, [keypad, keybox]) as emulator:
        yield channel, emulator, keypad, keybox
    bus.shutdown()


def _key(emulator: Emulator, twin: KeypadTwin, key: int) -> dict[str, Any]:
    return emulator.snapshot(twin)["keys"][key - 1]  # type: ignore[no-any-return]


def _pin(emulator: Emulator, twin: KeyboxTwin, pin: int) -> str:
    return str(emulator.snapshot(twin)["pins"][pin - 1]["state"])


def _tap(emulator: Emulator, twin: KeypadTwin, key: int) -> None:
    emulator.press(twin, key)
    emulator.release(twin, key)


def test_controlling_a_keypad(bench: tuple[str, Emulator, KeypadTwin, KeyboxTwin]) -> None:
    channel, emulator, keypad, _ = bench
    program = Program("Controlling a keypad in ten lines", channel)
    try:
        wait_until(lambda: _key(emulator, keypad, 2)["phases"] == ["blue", "off"])
        assert _key(emulator, keypad, 1)["phases"] == ["red", "green"]
        assert emulator.snapshot(keypad)["backlight"] == {"colour": "blue", "level": 32}
        emulator.press(keypad, 5)
        wait_until(lambda: _key(emulator, keypad, 5)["colour"] == "green")
        emulator.release(keypad, 5)
        wait_until(lambda: _key(emulator, keypad, 5)["colour"] == "off")
    finally:
        program.stop()


def test_controlling_a_keybox(bench: tuple[str, Emulator, KeypadTwin, KeyboxTwin]) -> None:
    channel, emulator, _, keybox = bench
    program = Program("Controlling a Keybox in ten lines", channel)
    try:
        wait_until(lambda: program.has("keybox") and program.finished(), 5.0)
        snapshot = emulator.snapshot(keybox)
        assert snapshot["pins"][11]["pwm_percent"] == 50
        assert snapshot["pins"][3]["state"] == "off"  # on(4), then reset(4)
    finally:
        program.stop()


def test_a_keypad_and_a_keybox_on_one_bus(
        bench: tuple[str, Emulator, KeypadTwin, KeyboxTwin],
        capsys: pytest.CaptureFixture[str]) -> None:
    channel, emulator, keypad, keybox = bench
    program = Program("A keypad and a Keybox on one bus", channel)
    try:
        wait_until(lambda: program.has("keypad", "keybox") and
                   emulator.snapshot(keypad)["nmt_state"] == "operational", 5.0)
        wait_until(lambda: emulator.snapshot(keybox)["nmt_state"] == "operational")
        _tap(emulator, keypad, 4)
        wait_until(lambda: _key(emulator, keypad, 4)["colour"] == "green")
        assert _pin(emulator, keybox, 4) == "high"
        emulator.run(lambda now: keybox.blow_fuse(4, now))
        wait_until(lambda: _key(emulator, keypad, 4)["colour"] == "red")  # the fault event
        assert _pin(emulator, keybox, 4) == "fault"
        _tap(emulator, keypad, 4)  # a press on the faulted output resets it
        wait_until(lambda: _key(emulator, keypad, 4)["colour"] == "off")
        assert _pin(emulator, keybox, 4) == "off"
        emulator.run(lambda now: keybox.replace_fuse(4, now))
        _tap(emulator, keypad, 4)
        wait_until(lambda: _key(emulator, keypad, 4)["colour"] == "green")
        assert _pin(emulator, keybox, 4) == "high"
        wait_until(lambda: program.names["keybox"].nmt_state is not None)  # its heartbeat came
    finally:
        program.stop()
    assert "Keybox state OPERATIONAL" in capsys.readouterr().out  # a health event
