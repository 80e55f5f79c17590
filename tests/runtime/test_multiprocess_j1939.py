"""Issue 13 across processes: ``blinkcan emulate keypad --nvm FILE`` in a child process on
``udp_multicast`` (hop limit 0), the Keypad driver here. The driver switches the keypad to
J1939; the child is stopped and started again on the same NVM file (a power cycle of the
emulated device: the protocol is stored); the driver drives it over J1939, then switches it
back to CANopen, where it boots and answers SDO again."""

from __future__ import annotations

import contextlib
import random
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import can
import pytest

from blinkcan.host import HostBus, Keypad, scan_j1939
from blinkcan.protocol import Frame
from blinkcan.runtime import to_frame
from tests.processes import multicast_bus, stop
from tests.runtime.test_multiprocess import _child_environment, _random_group

pytestmark = pytest.mark.multiprocess


@contextlib.contextmanager
def _emulate(channel: str, port: int, *arguments: str) -> Iterator[subprocess.Popen[bytes]]:
    child = subprocess.Popen(
        [sys.executable, "-m", "blinkcan", "emulate", "keypad", "-q", *arguments,
         "-i", "udp_multicast", "-c", channel, "--bus-kwargs", f"port={port}", "hop_limit=0"],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, env=_child_environment())
    try:
        yield child
    finally:
        stop(child)


def _wait_for(bus: can.BusABC, can_id: int, data: bytes, child: subprocess.Popen[bytes],
              timeout: float = 20.0) -> None:
    end = time.monotonic() + timeout
    while time.monotonic() < end and child.poll() is None:
        message = bus.recv(0.2)
        frame = to_frame(message) if message is not None else None
        if frame is not None and frame.can_id == can_id and frame.data == data:
            return
    output = child.communicate(timeout=5)[0] if child.poll() is not None else b""
    pytest.fail(f"no {can_id:03X}#{data.hex()} from the child: {output!r}")


def _heard(host: HostBus, can_id: int, data: bytes, action: Callable[[], object],
           timeout: float = 5.0) -> bool:
    """Whether ``can_id#data`` comes within ``timeout`` after ``action()``, heard through the
    driver's HostBus (its notifier reads the bus: no second reader)."""
    heard = threading.Event()

    def hear(frame: Frame, now: float) -> None:
        if frame.data == data:
            heard.set()

    remove = host.subscribe_extended(hear) if can_id > 0x7FF else host.subscribe(can_id, hear)
    try:
        action()
        return heard.wait(timeout)
    finally:
        remove()


def _revision(keypad: Keypad, child: subprocess.Popen[bytes]) -> str:
    """The J1939 software revision (§11), asked until the child answers (it may be starting)."""
    assert keypad.j1939 is not None
    end = time.monotonic() + 20
    while time.monotonic() < end and child.poll() is None:
        with contextlib.suppress(TimeoutError):
            return keypad.j1939.software_revision(timeout=0.5)
    pytest.fail("the keypad did not answer over J1939")


def test_switched_power_cycled_driven_over_j1939_and_switched_back(tmp_path: Path) -> None:
    nvm = str(tmp_path / "keypad.json")
    channel, port = _random_group(), random.randint(40000, 60000)
    bus = multicast_bus(channel, port)
    keypad: Keypad | None = None
    try:
        with _emulate(channel, port, "--nvm", nvm) as child:
            _wait_for(bus, 0x715, b"\x00", child)  # CANopen boot-up
            keypad = Keypad(bus, 0x15, sdo_timeout=1.0)
            keypad.set_led(2, "green")
            keypad.switch_to_j1939(confirm=True)
            assert keypad.protocol == "j1939"
            assert _revision(keypad, child) == "V2.6"
        with _emulate(channel, port, "--nvm", nvm) as child:  # power cycle: J1939 is stored
            assert _revision(keypad, child) == "V2.6"
            assert [f.address for f in scan_j1939(keypad.host, listen=0.5)] == [0x21]
            keypad.j1939.send("led_acknowledge", 1)  # type: ignore[union-attr]
            assert _heard(keypad.host, 0x18EFFF21, bytes.fromhex("0003030102FFFFFF"),
                          lambda: keypad.set_led(3, "red", blink="green"))  # §7a, §19
            assert _heard(keypad.host, 0x715, b"\x00", keypad.switch_to_canopen)  # boot-up
            time.sleep(0.2)  # the driver starts it and sends its picture again
            assert keypad.protocol == "canopen"
            assert keypad.identity().software_version == "V2.2"
            assert int(keypad.read("led_on_red")) & 0b100 == 0b100  # the picture, restored by PDO
    finally:
        if keypad is not None:
            keypad.close()
        bus.shutdown()


def test_emulate_and_keypad_commands_in_j1939_mode_across_processes() -> None:
    """``blinkcan emulate keypad --protocol j1939`` in one process, ``blinkcan keypad
    --protocol j1939 led 3 red`` in another, this process listening (LED acknowledge on)."""
    channel, port = _random_group(), random.randint(40000, 60000)
    bus = multicast_bus(channel, port)
    bus_options = ["-i", "udp_multicast", "-c", channel, "--bus-kwargs", f"port={port}",
                   "hop_limit=0"]
    keypad: Keypad | None = None
    try:
        with _emulate(channel, port, "--protocol", "j1939") as child:
            # the child may not listen yet: _revision asks until it answers
            keypad = Keypad(bus, protocol="j1939", verify=False)
            assert _revision(keypad, child) == "V2.6"
            keypad.j1939.send("led_acknowledge", 1)  # type: ignore[union-attr]

            def led_command() -> None:
                done = subprocess.run(
                    [sys.executable, "-m", "blinkcan", "keypad", "--protocol", "j1939",
                     *bus_options, "led", "3", "red"],
                    capture_output=True, text=True, timeout=60, env=_child_environment(),
                    check=False)
                assert done.stdout == "keypad 21h (J1939): key 3 red\n", done.stderr

            assert _heard(keypad.host, 0x18EFFF21, bytes.fromhex("0001030100FFFFFF"),
                          led_command, timeout=30)
    finally:
        if keypad is not None:
            keypad.close()
        bus.shutdown()
