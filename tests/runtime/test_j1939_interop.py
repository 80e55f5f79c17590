"""Address claim against can-j1939 (the PyPI J1939 stack, python-can and threads): its
ControllerApplication and the keypad twin in an Emulator on one ``virtual`` bus (J-5)."""

from __future__ import annotations

import time
import uuid
from collections.abc import Callable, Iterator

import can
import j1939
import pytest

from blinkcan.devices.keypad_j1939 import DEFAULT_NAME
from blinkcan.protocol import Frame
from blinkcan.runtime import Emulator
from blinkcan.twin import KeypadTwin


def claiming_keypad() -> KeypadTwin:
    """A keypad in J1939 mode with address claim at boot on (§20)."""
    twin = KeypadTwin(protocol="j1939")
    twin.power_on(0.0)
    twin.receive(Frame(0x18EF2100, bytes.fromhex("041B7401FFFFFFFF"), extended=True), 0.0)
    twin.power_off()
    return twin


@pytest.fixture
def bench() -> Iterator[tuple[KeypadTwin, j1939.ElectronicControlUnit]]:
    channel = f"j1939-interop-{uuid.uuid4().hex}"
    device_bus = can.Bus(interface="virtual", channel=channel)
    twin = claiming_keypad()
    ecu = j1939.ElectronicControlUnit()
    with Emulator(device_bus, [twin]):
        wait(lambda: twin.snapshot()["j1939"]["address_claim"] == "claimed")
        ecu.connect(interface="virtual", channel=channel)
        try:
            yield twin, ecu
        finally:
            ecu.disconnect()
    device_bus.shutdown()


def wait(condition: Callable[[], object], timeout: float = 5.0) -> None:
    end = time.monotonic() + timeout
    while not condition():
        assert time.monotonic() < end, "condition not met in time"
        time.sleep(0.02)


def test_a_lower_name_from_can_j1939_takes_the_keypads_address(
        bench: tuple[KeypadTwin, j1939.ElectronicControlUnit]) -> None:
    twin, ecu = bench
    stronger = j1939.Name(value=DEFAULT_NAME.value - 1)
    application = j1939.ControllerApplication(stronger, 0x21)
    ecu.add_ca(controller_application=application)
    application.start()
    try:
        wait(lambda: twin.snapshot()["j1939"]["source_address"] == 0x22)  # J-5: next upwards
        wait(lambda: application.state == j1939.ControllerApplication.State.NORMAL)
        assert application.device_address == 0x21
    finally:
        application.stop()


def test_a_higher_name_from_can_j1939_moves_away(
        bench: tuple[KeypadTwin, j1939.ElectronicControlUnit]) -> None:
    twin, ecu = bench
    weaker = j1939.Name(value=DEFAULT_NAME.value + 1)  # arbitrary-address capable too
    application = j1939.ControllerApplication(weaker, 0x21)
    ecu.add_ca(controller_application=application)
    application.start()
    try:
        wait(lambda: application.state == j1939.ControllerApplication.State.NORMAL
             and application.device_address == 0x22)  # the keypad defended 21h
        assert twin.snapshot()["j1939"]["source_address"] == 0x21
        assert twin.snapshot()["j1939"]["address_claim"] == "claimed"
    finally:
        application.stop()
