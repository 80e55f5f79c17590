"""The keypad twin in the Emulator on a virtual bus: python-canopen as the reference client."""

from __future__ import annotations

import time
import uuid
from collections.abc import Iterator

import can
import canopen
import pytest

from blinkcan.devices.model import Quirks
from blinkcan.formats.canopen_od import object_dictionary
from blinkcan.protocol import Frame
from blinkcan.runtime import Emulator, to_frame, to_message
from blinkcan.twin import KeyboxTwin, KeypadTwin


@pytest.fixture
def channel() -> str:
    return f"test-{uuid.uuid4().hex}"


@pytest.fixture
def host(channel: str) -> Iterator[can.BusABC]:
    bus = can.Bus(interface="virtual", channel=channel)
    yield bus
    bus.shutdown()


def wait_for(host: can.BusABC, can_id: int, timeout: float = 2.0) -> Frame:
    end = time.monotonic() + timeout
    while (left := end - time.monotonic()) > 0:
        message = host.recv(left)
        if message is not None and message.arbitration_id == can_id:
            frame = to_frame(message)
            assert frame is not None
            return frame
    raise AssertionError(f"no frame {can_id:03X}h within {timeout} s")


@pytest.mark.parametrize("quirks", ["firmware", "cia301"])
@pytest.mark.parametrize("kind", ["keypad", "keybox", "keypad2"])
def test_remote_node_reads_every_readable_object(channel: str, quirks: Quirks, kind: str) -> None:
    twin = (KeyboxTwin(quirks=quirks) if kind == "keybox"
            else KeypadTwin(quirks=quirks, manual="1.5" if kind == "keypad2" else "1.1"))
    node_id = twin.node_id
    network = canopen.Network()
    network.connect(interface="virtual", channel=channel)
    device_bus = can.Bus(interface="virtual", channel=channel)
    try:
        with Emulator(device_bus, [twin]):
            node = canopen.RemoteNode(node_id, object_dictionary(twin.description, node_id))
            network.add_node(node)
            readable = [e for e in twin.description.table if e.access.readable]
            assert len(readable) > 40
            for entry in readable:
                raw = node.sdo.upload(entry.index, entry.subindex)
                expected = entry.encode(entry.default_for(node_id))
                assert raw == expected, f"{entry.index:04X}h/{entry.subindex:02X} {entry.name}"
            assert node.sdo["Manufacturer device name"].raw == "BlinkMarine"
            if isinstance(twin, KeyboxTwin):
                node.sdo["Output state"]["Outputs HIGH"].raw = 0x0008  # pin 4 HIGH
                assert twin.outputs.state[3] == 1
                restore = node.sdo["Restore default parameters"][1]
                load = int.from_bytes(b"load", "little")
                if quirks == "firmware":  # errata K3: the stock client rejects 43h
                    with pytest.raises(canopen.SdoCommunicationError, match="0x43"):
                        restore.raw = load
                else:
                    restore.raw = load
            assert node.sdo["Identity object"]["Vendor-ID"].raw == 0x3E2
            node.sdo["Producer heartbeat time"].raw = 100
            assert twin.objects["producer_heartbeat_time"] == 100
            with pytest.raises(canopen.SdoAbortedError) as error:
                node.sdo["Producer heartbeat time"].raw = 0xFF00  # errata P1, K17
            assert error.value.code == 0x06090030
    finally:
        network.disconnect()
        device_bus.shutdown()


def test_keys_leds_and_heartbeat_through_the_bus(channel: str, host: can.BusABC) -> None:
    twin = KeypadTwin()
    device_bus = can.Bus(interface="virtual", channel=channel)
    try:
        with Emulator(device_bus, [twin]) as emulator:
            assert wait_for(host, 0x715).data == b"\x00"
            host.send(to_message(Frame(0x615, bytes.fromhex("2B17100032000000"))))
            assert wait_for(host, 0x595).data[0] == 0x60
            heartbeat = wait_for(host, 0x715)
            assert heartbeat.data == b"\x7f"
            host.send(to_message(Frame(0, b"\x01\x15")))
            assert wait_for(host, 0x715).data == b"\x05"
            emulator.press(twin, 7)
            assert wait_for(host, 0x195).data[:2] == b"\x40\x00"
            host.send(to_message(Frame(0x215, bytes.fromhex("4200000000000000"))))
            deadline = time.monotonic() + 2
            while emulator.run(lambda now: twin.objects["led_on_red"]) != 0x42:
                assert time.monotonic() < deadline
                time.sleep(0.005)
    finally:
        device_bus.shutdown()


def test_overlapping_sdo_requests_are_dropped_with_a_response_delay(
        channel: str, host: can.BusABC) -> None:
    twin = KeypadTwin()
    device_bus = can.Bus(interface="virtual", channel=channel)
    try:
        with Emulator(device_bus, [twin], response_delay=0.05):
            wait_for(host, 0x715)
            request = to_message(Frame(0x615, bytes.fromhex("4000100000000000")))
            host.send(request)
            host.send(request)  # arrives while the keypad is still answering: dropped
            wait_for(host, 0x595)
            with pytest.raises(AssertionError):
                wait_for(host, 0x595, timeout=0.2)
            host.send(request)  # after the reply: answered
            assert wait_for(host, 0x595).data[0] == 0x43
    finally:
        device_bus.shutdown()


def test_a_twin_that_raises_does_not_stop_the_emulator(channel: str, host: can.BusABC) -> None:
    class Broken(KeypadTwin):
        def receive(self, frame: Frame, now: float) -> list[Frame]:
            if frame.data[:1] == b"\xee":
                raise RuntimeError("boom")
            return super().receive(frame, now)

    twin = Broken()
    device_bus = can.Bus(interface="virtual", channel=channel)
    try:
        with Emulator(device_bus, [twin]) as emulator:
            wait_for(host, 0x715)
            host.send(to_message(Frame(0x615, b"\xee" + bytes(7))))
            host.send(to_message(Frame(0x615, bytes.fromhex("4000100000000000"))))
            assert wait_for(host, 0x595).data[0] == 0x43
            assert emulator.stats.twin_errors == 1
    finally:
        device_bus.shutdown()


def test_twins_are_only_called_on_the_emulators_loop_one_call_at_a_time(
        channel: str, host: can.BusABC) -> None:
    """Frames from the reader (run at once when the loop is idle), heartbeats and calls
    from the test's thread all reach the twin as the loop's work, never two at a time."""
    outside: list[str] = []
    busy = [False]

    class Watched(KeypadTwin):
        def _watch(self, what: str) -> None:
            if not emulator.scheduler.in_loop or busy[0]:
                outside.append(what)

        def receive(self, frame: Frame, now: float) -> list[Frame]:
            self._watch("receive")
            busy[0] = True
            try:
                return super().receive(frame, now)
            finally:
                busy[0] = False

        def advance(self, now: float) -> list[Frame]:
            self._watch("advance")
            return super().advance(now)

    twin = Watched(settings={"producer_heartbeat_time": 10})
    device_bus = can.Bus(interface="virtual", channel=channel)
    try:
        with Emulator(device_bus, [twin]) as emulator:
            wait_for(host, 0x715)
            read = to_message(Frame(0x615, bytes.fromhex("4000100000000000")))
            for _ in range(50):
                host.send(read)
                emulator.press(twin, 1)
                emulator.release(twin, 1)
                assert wait_for(host, 0x595).data[0] == 0x43
            assert emulator.stats.frames_received >= 50
    finally:
        device_bus.shutdown()
    assert outside == []


def test_two_keypads_on_one_bus_and_a_power_cycle(channel: str, host: can.BusABC) -> None:
    first, second = KeypadTwin(0x15), KeypadTwin(0x16)
    device_bus = can.Bus(interface="virtual", channel=channel)
    try:
        with Emulator(device_bus, [first, second]) as emulator:
            boot_ids = {wait_for(host, 0x715).can_id, wait_for(host, 0x716).can_id}
            assert boot_ids == {0x715, 0x716}
            assert emulator.power_cycle(second) == [Frame(0x716, b"\x00")]
    finally:
        device_bus.shutdown()


def test_keybox_fault_and_heartbeat_loss_on_the_bus(channel: str, host: can.BusABC) -> None:
    keybox = KeyboxTwin()
    device_bus = can.Bus(interface="virtual", channel=channel)
    try:
        with Emulator(device_bus, [keybox]) as emulator:
            wait_for(host, 0x70C)
            host.send(to_message(Frame(0x60C, bytes.fromhex("2316100132000100"))))  # 50 ms, node 1
            assert wait_for(host, 0x58C).data[0] == 0x60
            host.send(to_message(Frame(0x701, b"\x05")))
            host.send(to_message(Frame(0, b"\x01\x0c")))
            host.send(to_message(Frame(0x20C, bytes.fromhex("0000080000000000"))))  # pin 4 HIGH
            host.send(to_message(Frame(0x701, b"\x05")))
            deadline = time.monotonic() + 2
            while emulator.snapshot(keybox)["pins"][3]["state"] != "high":
                assert time.monotonic() < deadline
                host.send(to_message(Frame(0x701, b"\x05")))
                time.sleep(0.01)
            emulator.run(lambda now: keybox.blow_fuse(4, now))
            assert wait_for(host, 0x18C).data == bytes.fromhex("0800000000000000")
            time.sleep(0.2)  # the host heartbeat stops: outputs off, pre-operational
            snapshot = emulator.snapshot(keybox)
            assert snapshot["nmt_state"] == "pre-operational"
            assert snapshot["heartbeat_consumer"]["state"] == "lost"
    finally:
        device_bus.shutdown()


def test_sends_on_a_shut_down_bus_are_reported_once_with_a_count(
        channel: str, host: can.BusABC, caplog: pytest.LogCaptureFixture) -> None:
    twin = KeypadTwin()
    device_bus = can.Bus(interface="virtual", channel=channel)
    emulator = Emulator(device_bus, [twin]).start()
    try:
        wait_for(host, 0x715)
        host.send(to_message(Frame(0x615, bytes.fromhex("2B1710000A000000"))))  # 10 ms heartbeat
        assert wait_for(host, 0x595).data[0] == 0x60
        device_bus.shutdown()
        deadline = time.monotonic() + 5
        while emulator.stats.send_errors < 5:
            assert time.monotonic() < deadline, "the heartbeat stopped being sent"
            time.sleep(0.01)
    finally:
        emulator.stop()
        device_bus.shutdown()
    failures = emulator.stats.send_errors
    sends = [r.getMessage() for r in caplog.records if r.name == "blinkcan.runtime.emulator"]
    assert len(sends) == 2, sends  # the first failure, and the count at the end
    assert "send failed" in sends[0]
    assert f"{failures} frames could not be sent" in sends[1]


@pytest.mark.parametrize("frame", [Frame(0x595, bytes.fromhex("4300100091010f00")),
                                   Frame(0x18FF0021, b"\x01\x02", extended=True),
                                   Frame(0x080, b"")], ids=["sdo", "extended", "empty"])
def test_the_messages_a_port_sends_are_the_ones_to_message_makes(frame: Frame) -> None:
    """The port builds its Message without the constructor (runtime/canport.py): every field
    as python-can's constructor sets it."""
    from blinkcan.runtime import canport

    fast, made = canport._message_maker()(frame, 12.5), to_message(frame, 12.5)
    assert type(fast) is can.Message
    fields = [name for name in can.Message.__slots__ if name != "__weakref__"]
    assert {name: getattr(fast, name) for name in fields} == {
        name: getattr(made, name) for name in fields}
    assert fast.equals(made)
    assert to_frame(fast) == frame
