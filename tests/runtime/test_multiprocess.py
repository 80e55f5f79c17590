"""Across processes: ``blinkcan emulate`` in a child process, this process as the host, on
python-can's ``udp_multicast`` interface."""

from __future__ import annotations

import contextlib
import json
import os
import random
import subprocess
import sys
import time
from collections.abc import Iterator

import can
import pytest

from blinkcan.protocol import Frame
from blinkcan.runtime import to_frame, to_message

pytestmark = pytest.mark.multiprocess


def _multicast_bus(channel: str, port: int) -> can.BusABC:
    try:
        return can.Bus(interface="udp_multicast", channel=channel, port=port,
                       receive_own_messages=False)
    except (OSError, ImportError, can.CanError) as error:
        pytest.skip(f"udp_multicast unavailable here ({error}); on a machine without a default "
                    "route run: ip route add 224.0.0.0/4 dev lo")


@contextlib.contextmanager
def emulated(*devices: str) -> Iterator[tuple[can.BusABC, subprocess.Popen[bytes]]]:
    """``blinkcan emulate DEVICES`` in a child process on a fresh multicast group, and this
    process's bus on the same group; both closed afterwards."""
    # A group and a port of its own: Linux hands multicast to every socket on the port, so
    # two test runs on one machine would otherwise hear each other.
    channel = f"239.74.{random.randint(1, 254)}.{random.randint(1, 254)}"
    port = random.randint(40000, 60000)
    host = _multicast_bus(channel, port)
    child = subprocess.Popen(
        [sys.executable, "-m", "blinkcan", "emulate", *devices, "-q", "-i", "udp_multicast",
         "-c", channel],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
        env={**os.environ, "PYTHONUNBUFFERED": "1", "CAN_CONFIG": json.dumps({"port": port})},
    )
    try:
        yield host, child
    finally:
        child.terminate()
        try:
            child.wait(timeout=5)
        except subprocess.TimeoutExpired:
            child.kill()
        host.shutdown()


def test_keypad_emulated_in_another_process_answers() -> None:
    with emulated("keypad:0x21") as (host, child):
        frames: list[Frame] = []
        end = time.monotonic() + 20
        while time.monotonic() < end and Frame(0x721, b"\x00") not in frames:
            message = host.recv(0.5)
            if message is not None and (frame := to_frame(message)) is not None:
                frames.append(frame)
            if child.poll() is not None:
                break
        exited = child.poll() is not None
        output = child.communicate(timeout=5)[0] if exited else frames
        assert Frame(0x721, b"\x00") in frames, output
        host.send(to_message(Frame(0x621, bytes.fromhex("4000100000000000"))))
        end = time.monotonic() + 5
        while time.monotonic() < end:
            message = host.recv(0.5)
            if message is not None and message.arbitration_id == 0x5A1:
                assert bytes(message.data) == bytes.fromhex("430010009101 0B00".replace(" ", ""))
                break
        else:
            pytest.fail("no SDO reply across processes")


def test_drivers_in_this_process_twins_in_another() -> None:
    from blinkcan.host import Keybox, Keypad

    with emulated("keypad", "keybox") as (host_bus, _):
        end = time.monotonic() + 20
        booted: set[int] = set()
        while time.monotonic() < end and booted != {0x70C, 0x715}:
            message = host_bus.recv(0.5)
            if message is not None and bytes(message.data) == b"\x00":
                booted.add(message.arbitration_id)
        assert booted == {0x70C, 0x715}, "the twins did not boot in the child process"
        keypad = Keypad(host_bus, sdo_timeout=1.0)
        keybox = Keybox(keypad.host, sdo_timeout=1.0)
        try:
            assert keypad.identity().software_version == "V2.2"
            keypad.write("led_on_red", 0x081)
            assert keypad.read("led_on_red") == 0x081
            keybox.on(7)
            assert keybox.state(7) == "high"
        finally:
            keybox.close()
            keypad.close()
