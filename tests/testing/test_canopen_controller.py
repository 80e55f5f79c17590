"""A python-canopen controller on the rig (issue 24): ``canopen.Network(rig.bus).connect()`` as
written, a ``RemoteNode`` from our EDS; its SDO, NMT, PDO and heartbeat waits run in virtual
time (``blinkcan.runtime.virtual_waits``), deterministically, and are undone at ``rig.close()``."""

from __future__ import annotations

import threading
from collections.abc import Iterator
from typing import Any

import can
import canopen
import pytest
from canopen.nmt import NmtError
from canopen.sdo.client import SdoClient
from canopen.sdo.exceptions import SdoCommunicationError

from blinkcan import Keybox
from blinkcan.devices.registry import describe_device
from blinkcan.formats.shipped import shipped_eds
from blinkcan.protocol.cob import HEARTBEAT
from blinkcan.runtime.virtual_waits import installed_waits
from blinkcan.testing import Rig
from blinkcan.twin import KeyboxTwin

KEYBOX_EDS = str(shipped_eds(describe_device("keybox")))


@pytest.fixture
def bench() -> Iterator[tuple[Rig, KeyboxTwin, Any]]:
    with Rig() as rig:
        twin = rig.add(KeyboxTwin(node_id=0x0C))
        network = canopen.Network(rig.bus)
        network.connect()
        node = network.add_node(0x0C, KEYBOX_EDS)
        yield rig, twin, node
        network.disconnect()


def test_sdo_reads_and_writes_and_nmt_start_in_virtual_time(
        bench: tuple[Rig, KeyboxTwin, Any]) -> None:
    rig, twin, node = bench
    device_type = describe_device("keybox").table.get(0x1000, 0)
    assert device_type is not None
    assert node.sdo[0x1000].raw == device_type.default
    node.sdo[0x1017].raw = 50  # producer heartbeat, ms
    node.nmt.state = "OPERATIONAL"
    assert node.nmt.wait_for_heartbeat(1.0) == "OPERATIONAL"
    assert rig.now == pytest.approx(0.05)  # the first heartbeat, 50 ms after the write
    assert twin.snapshot()["nmt_state"] in ("operational", "OPERATIONAL")
    assert node.sdo[0x1017].raw == 50


def test_an_sdo_timeout_takes_its_configured_time_in_virtual_time(
        bench: tuple[Rig, KeyboxTwin, Any]) -> None:
    """Was: the client waited on a real queue (0.3 wall seconds) while the notifier's thread
    ran the simulation far ahead (a minute of virtual time per recv)."""
    rig, twin, node = bench
    node.sdo.RESPONSE_TIMEOUT = 0.5
    rig.drop(lambda frame: frame.can_id == 0x580 + twin.node_id)  # its SDO replies
    start = rig.now
    with pytest.raises(SdoCommunicationError, match="No SDO response"):
        _ = node.sdo[0x1000].raw
    assert rig.now - start == pytest.approx(0.5)
    aborts = [when for when, frame in rig.frames
              if frame.can_id == 0x60C and frame.data[0] == 0x80]
    assert aborts == pytest.approx([start + 0.5])  # the client's abort, when it gave up


def test_a_lost_heartbeat_is_noticed_after_the_timeout_in_virtual_time(
        bench: tuple[Rig, KeyboxTwin, Any]) -> None:
    rig, twin, node = bench
    node.sdo[0x1017].raw = 100
    states: list[int] = []
    node.nmt.add_heartbeat_callback(states.append)
    rig.advance(0.55)
    assert len(states) == 5
    rig.stop_heartbeat(twin)
    start = rig.now
    with pytest.raises(NmtError, match="No boot-up or heartbeat"):
        node.nmt.wait_for_heartbeat(timeout=0.3)
    assert rig.now - start == pytest.approx(0.3)
    assert len(states) == 5


def test_a_power_cycle_is_a_boot_up_to_python_canopen(
        bench: tuple[Rig, KeyboxTwin, Any]) -> None:
    rig, twin, node = bench
    rig.power_off(twin)
    start = rig.now
    rig.scheduler.call_later(0.2, lambda: rig.power_on(twin))  # while python-canopen waits
    node.nmt.wait_for_bootup(timeout=1.0)
    assert rig.now == pytest.approx(start + 0.2)
    assert node.nmt.state == "PRE-OPERATIONAL"
    with pytest.raises(NmtError, match="boot-up"):
        node.nmt.wait_for_bootup(timeout=0.5)


def test_a_tpdo_map_read_from_our_eds_calls_back_on_a_blown_fuse(
        bench: tuple[Rig, KeyboxTwin, Any]) -> None:
    rig, twin, node = bench
    node.tpdo.read()  # the PDO configuration, by SDO, as the EDS maps it
    faults = node.tpdo[1]
    heard: list[tuple[float, bytes]] = []
    faults.add_callback(lambda pdo: heard.append((pdo.timestamp, bytes(pdo.data))))
    node.nmt.state = "OPERATIONAL"
    node.sdo[0x2001][9].raw = 1  # output 9 HIGH (KBX §19)
    rig.advance(0.1)
    start = rig.now
    rig.scheduler.call_later(0.25, lambda: rig.blow_fuse(twin, 9))  # while python-canopen waits
    when = faults.wait_for_reception(timeout=1.0)
    assert when == pytest.approx(start + 0.25)
    assert rig.now == pytest.approx(start + 0.25)
    assert len(heard) == 1
    assert heard[-1][1][1] & 0x01  # output 9: bit 0 of the second byte


def test_a_blocking_sdo_call_in_a_pdo_callback_times_out_as_on_a_real_notifier(
        bench: tuple[Rig, KeyboxTwin, Any]) -> None:
    """A python-canopen callback runs on the notifier's thread: an SDO request made there
    never hears its reply (the thread that would deliver it is busy). The rig says the same."""
    rig, twin, node = bench
    node.tpdo.read()
    node.nmt.state = "OPERATIONAL"
    outcome: list[str] = []

    def read_in_callback(pdo: Any) -> None:
        try:
            outcome.append(f"read {node.sdo[0x1000].raw}")
        except SdoCommunicationError as error:
            outcome.append(str(error))

    node.tpdo[1].add_callback(read_in_callback)
    node.sdo[0x2001][9].raw = 1
    rig.blow_fuse(twin, 9)
    rig.advance(1.0)
    assert outcome[:1] == ["No SDO response received"]


def _scenario() -> list[tuple[float, int, bytes]]:
    with Rig() as rig:
        twin = rig.add(KeyboxTwin(node_id=0x0C))
        network = canopen.Network(rig.bus)
        network.connect()
        node: Any = network.add_node(0x0C, KEYBOX_EDS)
        node.sdo[0x1017].raw = 20
        node.nmt.state = "OPERATIONAL"
        node.tpdo.read()
        rig.advance(0.5)
        node.sdo[0x2001][3].raw = 1
        rig.scheduler.call_later(0.1, lambda: rig.blow_fuse(twin, 3))
        assert node.tpdo[1].wait_for_reception(1.0) is not None
        rig.advance(0.5)
        network.disconnect()
        return [(when, frame.can_id, frame.data) for when, frame in rig.frames]


def test_two_runs_give_the_same_frames_at_the_same_times() -> None:
    first = _scenario()
    assert len(first) > 40
    assert _scenario() == first


def test_the_waits_are_put_back_when_the_rig_closes() -> None:
    original = SdoClient.__dict__["read_response"]
    with Rig() as rig:
        canopen.Network(rig.bus).connect()
        assert "canopen.sdo.client.SdoClient.read_response" in installed_waits()
        with Rig() as other:  # a second rig shares them; its close keeps them for the first
            canopen.Network(other.bus).connect()
        assert SdoClient.__dict__["read_response"] is not original
    assert SdoClient.__dict__["read_response"] is original
    assert installed_waits() == []


def test_a_real_bus_keeps_real_time_while_a_rig_is_open() -> None:
    """A client on python-can's virtual bus waits for its reply on the wall clock: a reply put
    in its queue 50 ms later (by another thread) is taken."""
    with Rig() as rig:
        canopen.Network(rig.bus).connect()
        real = canopen.Network(can.Bus(interface="virtual", channel="h24-real-time",
                                       receive_own_messages=False))
        real.connect()
        try:
            node = real.add_node(0x05, KEYBOX_EDS)
            reply = bytes([0x43, 0x00, 0x10, 0x00, 1, 2, 3, 4])
            threading.Timer(0.05, node.sdo.responses.put, (reply,)).start()
            assert node.sdo.read_response() == reply
        finally:
            real.disconnect()
    assert HEARTBEAT  # the rig is closed meanwhile, nothing else to check


def test_pythons_canopen_sync_producer_runs_on_the_virtual_clock(
        bench: tuple[Rig, KeyboxTwin, Any]) -> None:
    rig, _, node = bench
    node.network.sync.start(0.1)
    rig.advance(0.55)
    node.network.sync.stop()
    rig.advance(0.5)
    assert [when for when, frame in rig.frames if frame.can_id == 0x080] == pytest.approx(
        [0.0, 0.1, 0.2, 0.3, 0.4, 0.5])


def test_blinkcan_drivers_and_python_canopen_share_the_rig_bus(
        bench: tuple[Rig, KeyboxTwin, Any]) -> None:
    rig, _, node = bench
    keybox = Keybox(rig.bus, 0x0C)
    keybox.on(4)  # the driver's SDO, answered in virtual time
    assert node.sdo["Single pin state"][4].raw == 1  # python-canopen reads what it did
    node.sdo["Single pin state"][4].raw = 0
    assert keybox.states()[4] == "off"
    keybox.close()
