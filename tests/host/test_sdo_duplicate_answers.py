"""A second device at one node id whose replies trail by more than the driver's whole
confirmation (a slow device, a loaded second emulator) answered nothing the driver awaited:
every second reply came when no request waited, was discarded, and the driver went on with
two devices at one id unnoticed (issue 22's brief). A reply that answers a request already
answered is a second device's: the next request to that node says so."""

from __future__ import annotations

from collections.abc import Iterator

import can
import pytest

from blinkcan.devices.registry import models
from blinkcan.host import SharedNodeIdError
from blinkcan.host.registry import driver_class
from blinkcan.protocol.cob import SDO_TX
from blinkcan.protocol.sdo_client import SdoTimeoutError
from blinkcan.runtime import Emulator
from blinkcan.runtime.simbus import SimulatedBus
from blinkcan.testing import Rig
from blinkcan.twin import KeypadTwin
from blinkcan.twin.registry import build_twin

MODELS = [model.name for model in models()]
LATE = 1.0  # seconds: far more than the whole confirmation takes (it takes no simulated time)


@pytest.fixture
def rig() -> Iterator[Rig]:
    with Rig() as rig:
        yield rig


def _late_twin(rig: Rig, name: str) -> Emulator:
    """A second ``name`` twin at the first's node id, on an emulator of its own that answers
    ``LATE`` seconds after each request (and drops requests meanwhile, as busy devices do)."""
    emulator = Emulator(SimulatedBus(rig.network, "late"), [build_twin(name)],
                        response_delay=LATE, power_up_spread=0.0)
    return emulator.start()


@pytest.mark.parametrize("name", MODELS)
def test_a_late_second_device_is_reported_at_the_next_request(rig: Rig, name: str) -> None:
    first = rig.add(build_twin(name))
    late = _late_twin(rig, name)
    try:
        rig.settle()
        driver = driver_class(name)(rig.bus, first.node_id)  # only the first answered in time
        rig.advance(2 * LATE)  # the late device's answer to the first read comes meanwhile
        with pytest.raises(SharedNodeIdError, match=rf"^two devices answer at node "
                                                    rf"{first.node_id:02X}h"):
            driver.read("device_type")
        driver.close()
    finally:
        late.stop()
        assert late.bus is not None
        late.bus.shutdown()  # the test made it: python-can warns of a bus never shut down


def test_a_late_reply_after_a_timeout_is_not_a_second_device(rig: Rig) -> None:
    """One device whose reply missed the timeout: its late reply answers nothing answered."""
    twin = rig.add(KeypadTwin(node_id=0x15))
    keypad = driver_class("keypad")(rig.bus, 0x15)
    undo = rig.delay(lambda frame: frame.can_id == 0x595, 1.5 * keypad.sdo.timeout)
    with pytest.raises(SdoTimeoutError, match="no reply within"):
        keypad.sdo.upload(0x1000, 0, retries=0)
    undo()
    rig.advance(2 * LATE)
    for _ in range(3):
        assert keypad.read("device_type") == twin.objects.get_int("device_type")
    keypad.close()


def test_the_same_object_read_twice_by_one_device_is_fine(rig: Rig) -> None:
    twin = rig.add(KeypadTwin(node_id=0x15))
    keypad = driver_class("keypad")(rig.bus, 0x15)
    for _ in range(3):
        assert keypad.read("device_type") == twin.objects.get_int("device_type")
        rig.advance(LATE)
    keypad.close()


def test_another_clients_answer_for_an_object_read_is_not_a_second_device(rig: Rig) -> None:
    """A tool on the bus reads 1000h too: its answer duplicates ours, yet one device answers;
    the next request looks (one read gathered) and goes on."""
    twin = rig.add(KeypadTwin(node_id=0x15))
    keypad = driver_class("keypad")(rig.bus, 0x15)
    device_type = keypad.read("device_type")
    tool = SimulatedBus(rig.network, "a tool")
    tool.send(can.Message(arbitration_id=0x615, is_extended_id=False,
                          data=bytes.fromhex("4000100000000000")))
    tool.shutdown()
    rig.advance(LATE)
    assert keypad.read("device_type") == device_type == twin.objects.get_int("device_type")
    assert keypad.read("device_type") == device_type
    keypad.close()


@pytest.mark.parametrize("name", MODELS)
def test_late_replies_to_a_request_and_its_resync_that_timed_out_are_no_second_device(
        rig: Rig, name: str) -> None:
    """One device whose replies come 2.4 timeouts late until the delay ends (hatk8 fuzz, seeds
    36/51/67): the read of 1017h and the resync read after it time out; the same object is read
    again at once and answered; then the late reply to the first read comes (it answers a
    request that got no answer, not the one answered), and the resync read's late reply comes
    while the next request gathers the answers to a read of 1000h. Neither is a second
    device's: every read goes on and returns the device's value."""
    twin = rig.add(build_twin(name))
    driver = driver_class(name)(rig.bus, twin.node_id)
    timeout = driver.sdo.timeout
    undo = rig.delay(lambda frame: frame.can_id == SDO_TX + twin.node_id, 2.4 * timeout)
    with pytest.raises(SdoTimeoutError, match="no reply within"):
        driver.sdo.upload(0x1017, 0, retries=1)  # the read, then the resync read, time out
    undo()
    heartbeat = driver.sdo.upload(0x1017, 0)  # in time: the late replies are still on the way
    assert int.from_bytes(heartbeat, "little") == twin.objects.get_int("producer_heartbeat_time")
    rig.advance(0.45 * timeout)  # the first read's late reply came meanwhile
    for _ in range(3):  # the first gathers while the resync read's late reply comes
        assert driver.sdo.upload(0x1017, 0) == heartbeat
        rig.advance(timeout)
    assert driver.sdo.channel.late_replies == 2
    driver.close()
