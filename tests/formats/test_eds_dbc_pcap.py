"""EDS, DBC and pcap files: written from the tables, read back by the tools they are for."""

from __future__ import annotations

import io
import shutil
import subprocess
import uuid
from collections.abc import Callable
from pathlib import Path

import can
import canopen
import cantools
import pytest
from canopen.objectdictionary import import_od

from blinkcan.devices.registry import describe_device
from blinkcan.formats.canopen_od import object_dictionary
from blinkcan.formats.dbc import dbc_text
from blinkcan.formats.eds import eds_text
from blinkcan.formats.pcap import PcapError, read_pcap, write_pcap
from blinkcan.formats.shipped import shipped_eds
from blinkcan.protocol import Frame
from blinkcan.runtime import Emulator
from blinkcan.twin import KeyboxTwin, KeypadTwin
from tests.conftest import frame


@pytest.mark.parametrize("device", ["keypad", "keybox", "keypad@1.5"])
def test_shipped_eds_files_match_a_fresh_export(device: str) -> None:
    description = describe_device(device)
    assert shipped_eds(description).read_text() == eds_text(description)


@pytest.mark.parametrize("device", ["keypad", "keybox", "keypad@1.5"])
def test_import_od_reads_the_eds_back_identically(device: str, tmp_path: Path) -> None:
    description = describe_device(device)
    path = tmp_path / "device.eds"
    path.write_text(eds_text(description))
    node = description.default_node_id
    ours, theirs = object_dictionary(description, node), import_od(str(path), node)

    def entries(od: canopen.ObjectDictionary) -> dict[tuple[int, int], tuple[object, ...]]:
        found: dict[tuple[int, int], tuple[object, ...]] = {}
        for obj in od.values():
            for var in (obj.values() if hasattr(obj, "subindices") else [obj]):
                found[var.index, var.subindex] = (var.name, var.data_type, var.access_type,
                                                  var.default)
        return found

    assert entries(theirs) == entries(ours)


@pytest.mark.parametrize(("device", "make_twin"), [
    ("keypad", KeypadTwin), ("keybox", KeyboxTwin),
    ("keypad@1.5", lambda: KeypadTwin(manual="1.5"))])
def test_a_remote_node_from_the_shipped_eds_reads_every_object(device: str,
                                                               make_twin: Callable[[], object]
                                                               ) -> None:
    description = describe_device(device)
    twin = make_twin()
    assert isinstance(twin, (KeypadTwin, KeyboxTwin))
    channel = f"eds-{uuid.uuid4().hex}"
    device_bus = can.Bus(interface="virtual", channel=channel)
    network = canopen.Network()
    network.connect(interface="virtual", channel=channel)
    try:
        with Emulator(device_bus, [twin]):
            node = network.add_node(twin.node_id, str(shipped_eds(description)))
            for obj in node.object_dictionary.values():
                for var in (obj.values() if hasattr(obj, "subindices") else [obj]):
                    if "r" in var.access_type:
                        assert node.sdo.upload(var.index, var.subindex) is not None
            assert node.sdo["Device type"].raw == description.table["device_type"].default
    finally:
        network.disconnect()
        device_bus.shutdown()


@pytest.mark.parametrize(("device", "text", "expected"), [
    # every PDO example frame of both manuals, decoded by cantools with our DBC
    ("keypad", "195 08 00 00 00 00", {"keys_4": 1}),
    ("keypad", "195 80 00 00 00 00", {"keys_8": 1}),
    ("keypad", "195 21 00 00 00 00", {"keys_1": 1, "keys_6": 1}),
    ("keypad", "195 00 08 00 00 00", {"keys_12": 1}),
    ("keypad", "215 01 00 00 00 00 00 00 00", {"red_1": 1}),
    ("keypad", "215 42 00 00 00 00 00 00 00", {"red_2": 1, "red_7": 1}),
    ("keypad", "215 00 00 01 00 00 00 00 00", {"green_5": 1}),
    ("keypad", "215 00 11 00 00 00 00 00 00", {"green_1": 1, "red_9": 1}),
    ("keypad", "215 00 00 00 88 00 00 00 00", {"blue_4": 1, "blue_8": 1}),
    ("keypad", "215 00 CC 00 00 00 00 00 00", {"red_11": 1, "red_12": 1, "green_3": 1,
                                               "green_4": 1}),
    ("keypad", "315 09 00 00 00 00 00 00 00", {"red_1": 1, "red_4": 1}),
    ("keypad", "315 00 00 11 00 00 00 00 00", {"green_5": 1, "green_9": 1}),
    ("keypad", "315 00 00 00 01 00 00 00 00", {"blue_1": 1}),
    ("keypad", "315 00 00 CC 00 03 00 00 00", {"green_7": 1, "green_8": 1, "green_11": 1,
                                               "green_12": 1, "blue_9": 1, "blue_10": 1}),
    ("keypad", "415 08 00 00 00 00 00 00 00", {"level": 8}),
    ("keypad", "515 10 00 00 00 00 00 00 00", {"level": 16}),
    ("keybox", "20C 81 00 00 00 00 00 00 00", {"off_1": 1, "off_8": 1}),
    ("keybox", "20C 00 00 00 03 00 00 00 00", {"high_9": 1, "high_10": 1}),
    ("keybox", "20C 01 00 02 00 00 00 00 00", {"off_1": 1, "high_2": 1}),
    ("keybox", "18C 18 00 00 00 00 00 00 00", {"faults_4": 1, "faults_5": 1}),
    ("keybox", "18C 00 01 00 00 00 00 00 00", {"faults_9": 1}),
])
def test_cantools_decodes_the_manual_pdo_examples(device: str, text: str,
                                                  expected: dict[str, int]) -> None:
    database = _load(device)
    example = frame(text)
    decoded = database.decode_message(example.can_id, example.data)
    assert isinstance(decoded, dict)
    assert {name: value for name, value in decoded.items() if value} == expected


def _load(device: str) -> cantools.database.can.Database:
    database = cantools.database.load_string(dbc_text(describe_device(device)))
    assert isinstance(database, cantools.database.can.Database)
    return database


def test_dbc_heartbeat_states() -> None:
    decoded = _load("keybox").decode_message(0x70C, b"\x7f")
    assert isinstance(decoded, dict)
    assert str(decoded["state"]) == "pre_operational"


FRAMES = [(1.5, Frame(0x715, b"\x00")), (1.500001, Frame(0x615, bytes.fromhex("4000100000000000"))),
          (2.25, Frame(0x18EF2100, bytes.fromhex("041B8000FFFFFFFF"), True)),
          (3.0, Frame(0x000, b"\x01\x15"))]


def test_pcap_round_trip_is_byte_identical() -> None:
    first = io.BytesIO()
    write_pcap(first, FRAMES)
    read = list(read_pcap(io.BytesIO(first.getvalue())))
    assert [f for _, f in read] == [f for _, f in FRAMES]
    assert [round(t, 6) for t, _ in read] == [t for t, _ in FRAMES]
    second = io.BytesIO()
    write_pcap(second, read)
    assert second.getvalue() == first.getvalue()


def test_pcap_refuses_other_files() -> None:
    with pytest.raises(PcapError, match="not a little-endian"):
        list(read_pcap(io.BytesIO(b"\x00" * 24)))


def test_tshark_dissects_the_capture_as_canopen(tmp_path: Path) -> None:
    tshark = shutil.which("tshark")
    if tshark is None:
        pytest.skip("tshark is not installed (apt-get install tshark to run this check)")
    path = tmp_path / "capture.pcap"
    with path.open("wb") as stream:
        write_pcap(stream, FRAMES)
    result = subprocess.run([tshark, "-r", str(path), "-d", "can.subdissector,canopen"],
                            capture_output=True, text=True, timeout=60, check=True)
    lines = result.stdout.splitlines()
    assert len(lines) == len(FRAMES)
    assert "CANopen" in result.stdout
