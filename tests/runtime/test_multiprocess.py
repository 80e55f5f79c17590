"""Across processes: ``blinkcan emulate`` in a child process, this process (or ``blinkcan
scan`` in another) as the host, on python-can's ``udp_multicast`` interface with hop limit 0:
delivered between the processes of this machine, never sent on a network."""

from __future__ import annotations

import contextlib
import os
import random
import socket
import subprocess
import sys
import time
from collections.abc import Iterator

import can
import pytest

from blinkcan.cli.bus_options import DEFAULT_GROUP
from blinkcan.protocol import Frame
from blinkcan.runtime import to_frame, to_message
from tests.processes import multicast_bus, stop

pytestmark = pytest.mark.multiprocess




def _random_group() -> str:
    return f"239.74.{random.randint(1, 254)}.{random.randint(1, 254)}"


def _child_environment() -> dict[str, str]:
    """This environment without python-can configuration: the command line's default bus."""
    environment = {name: value for name, value in os.environ.items()
                   if not name.startswith("CAN_")}
    return {**environment, "PYTHONUNBUFFERED": "1", "COLUMNS": "200"}


@contextlib.contextmanager
def emulated(*devices: str, channel: str | None = None
             ) -> Iterator[tuple[can.BusABC, subprocess.Popen[bytes]]]:
    """``blinkcan emulate DEVICES`` in a child process on a fresh multicast group, and this
    process's bus on the same group; both closed afterwards."""
    # A group and a port of its own: Linux hands multicast to every socket on the port, so
    # two test runs on one machine would otherwise hear each other.
    channel = channel or _random_group()
    port = random.randint(40000, 60000)
    host = multicast_bus(channel, port)
    child = subprocess.Popen(
        [sys.executable, "-m", "blinkcan", "emulate", *devices, "-q", "-i", "udp_multicast",
         "-c", channel, "--bus-kwargs", f"port={port}", "hop_limit=0"],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, env=_child_environment(),
    )
    try:
        yield host, child
    finally:
        stop(child)
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


def test_emulate_and_scan_in_two_processes_find_each_other_on_the_default_bus() -> None:
    """No bus options but a port of the test's own: the command line's default bus, named in
    the banner, crosses processes."""
    port = random.randint(40000, 60000)
    blinkcan = [sys.executable, "-m", "blinkcan"]
    emulator = subprocess.Popen([*blinkcan, "emulate", "keypad", "keybox", "-q",
                                 "--bus-kwargs", f"port={port}"],
                                stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                                env=_child_environment())
    try:
        assert emulator.stdout is not None
        banner = emulator.stdout.readline()
        assert f"on udp_multicast {DEFAULT_GROUP}:{port} (hop limit 0, this machine only)" in (
            banner), banner
        scan = subprocess.run([*blinkcan, "scan", "--bus-kwargs", f"port={port}"],
                              check=False, capture_output=True, text=True, timeout=60,
                              env=_child_environment())
    finally:
        emulator.terminate()
        emulator.communicate(timeout=10)
    assert scan.returncode == 0, scan.stdout + scan.stderr
    rows = [line for line in scan.stdout.splitlines() if "h " in line]
    assert any("0Ch" in row and "keybox" in row for row in rows), scan.stdout
    assert any("15h" in row and "keypad" in row for row in rows), scan.stdout


def _capture() -> socket.socket:
    try:
        capture = socket.socket(socket.AF_PACKET, socket.SOCK_RAW, socket.ntohs(0x0003))
    except (AttributeError, OSError) as error:
        pytest.skip(f"no packet capture here ({error})")
    capture.setblocking(False)
    return capture


def test_the_multicast_frames_never_leave_the_machine() -> None:
    """A capture on every interface while the twins boot and answer: IGMP reports for the group
    go out (that is how the kernel joins it, and shows the capture sees outgoing packets), the
    CAN frames in UDP to the group's port do not."""
    capture = _capture()
    channel = _random_group()
    group = socket.inet_aton(channel)
    try:
        with emulated("keypad:0x22", channel=channel) as (host, _):
            end = time.monotonic() + 20
            while time.monotonic() < end:
                message = host.recv(0.5)
                if message is not None and message.arbitration_id == 0x722:
                    break
            else:
                pytest.fail("the twin did not boot in the child process")
            outgoing = _outgoing_packets(capture)
    finally:
        capture.close()
    own_group = [packet for packet in outgoing if group in packet]
    if not any(packet[9] == 2 for packet in own_group):  # IP protocol 2: IGMP
        pytest.skip("the capture saw no IGMP report of the group; cannot judge")
    assert [packet for packet in own_group if packet[9] == 17] == [], (
        "UDP to the multicast group left the machine")


def _outgoing_packets(capture: socket.socket) -> list[bytes]:
    """IPv4 packets sent out of interfaces other than loopback (from the IP header on)."""
    packets: list[bytes] = []
    while True:
        try:
            data, (interface, protocol, kind, *_) = capture.recvfrom(65535)
        except BlockingIOError:
            return packets
        if interface != "lo" and protocol == 0x0800 and kind == socket.PACKET_OUTGOING:
            packets.append(data[14:])
