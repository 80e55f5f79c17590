"""The EDS files checked by tools nobody here wrote: CanFestival's objdictgen, eds-utils and
python-canopen (all from PyPI, in the ``dev`` extra; a test skips only where one is not
installed).

Deliberate findings: eds-utils reports the rev 1.1 keypad's 1600h/1601h entries, which map the
16-bit LED mask objects with 12 bits each, because that is the frame the keypad acts on (PKP
§11/§12, errata P7; ``devices/keypad.py: _eds_led_mappings``). Nothing else is accepted.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import canopen
import pytest
from canopen.objectdictionary import import_od

from blinkcan.devices.model import QUIRK_PROFILES, DeviceDescription
from blinkcan.devices.registry import describe_device, models
from blinkcan.formats.eds import eds_text
from blinkcan.formats.shipped import shipped_eds
from blinkcan.protocol import Frame
from blinkcan.protocol.cob import RPDO1
from blinkcan.twin import KeypadTwin

#: every registered model, generation and quirk profile: "model@generation:quirks"
DEVICES = [f"{model.name}@{generation}:{quirks}" for model in models()
           for generation in model.generations for quirks in QUIRK_PROFILES]

#: the findings eds-utils may report, per device: 1600h/1601h of rev 1.1 (see the docstring)
DELIBERATE = {
    ("pkp-2600-si", "1.1"): {
        f"RPDO {pdo} mapping value at subindex 0x0{sub} had the wrong mapped object "
        f"size: 0x200{pdo + 1}0{sub}0C -> 0x200{pdo + 1}0{sub}10"
        for pdo in (0, 1) for sub in (1, 2, 3)},
}


def _description(device: str) -> DeviceDescription:
    name, _, quirks = device.partition(":")
    return describe_device(name, quirks or "firmware")  # "name@generation", quirks


def _files(device: str, tmp_path: Path) -> list[Path]:
    """The shipped file (firmware profile) and a fresh export of ``device``."""
    description = _description(device)
    exported = tmp_path / "exported.eds"
    exported.write_text(eds_text(description))
    return [exported] + ([shipped_eds(description)] if description.quirks == "firmware" else [])


def _canopen_values(path: Path) -> dict[tuple[int, int], object]:
    od = import_od(str(path), 0)  # node 0: $NODEID entries read as their offset, as objdictgen
    found: dict[tuple[int, int], object] = {}
    for obj in od.values():
        for var in (obj.values() if hasattr(obj, "subindices") else [obj]):
            found[var.index, var.subindex] = var.default
    return found


@pytest.mark.parametrize("device", DEVICES)
def test_objdictgen_loads_the_eds_with_python_canopens_values(device: str, tmp_path: Path
                                                             ) -> None:
    objdictgen = pytest.importorskip("objdictgen")
    for path in _files(device, tmp_path):
        node: Any = objdictgen.LoadFile(str(path))  # refused StorageLocation and Unit on main
        theirs = _canopen_values(path)
        assert sorted(node.GetIndexes()) == sorted({index for index, _ in theirs})
        for (index, sub), value in theirs.items():
            entry = node.GetEntry(index)
            got = entry[sub] if isinstance(entry, list) else entry
            assert got == value, f"{path.name} {index:04X}sub{sub}: {got!r} != {value!r}"


@pytest.mark.parametrize("device", DEVICES)
def test_eds_utils_finds_only_the_documented_deliberate_findings(device: str, tmp_path: Path
                                                                 ) -> None:
    read_eds = pytest.importorskip("eds_utils.core.file_io.read_eds")
    for path in _files(device, tmp_path):
        _, findings = read_eds.read_eds(str(path))
        stripped = {re.sub(r"^AUTO-FIXED: ", "", finding) for finding in findings}
        description = _description(device)
        wanted = DELIBERATE.get((description.model, description.generation), set())
        assert stripped == wanted, path.name


@pytest.mark.parametrize("device", DEVICES)
def test_device_info_has_every_cia306_key(device: str, tmp_path: Path) -> None:
    text = eds_text(_description(device))
    section = text.split("[DeviceInfo]\n", 1)[1].split("\n\n", 1)[0]
    keys = {line.split("=", 1)[0] for line in section.splitlines()}
    assert keys >= {"VendorName", "VendorNumber", "ProductName", "ProductNumber",
                    "RevisionNumber", "OrderCode", "SimpleBootUpMaster", "SimpleBootUpSlave",
                    "Granularity", "DynamicChannelsSupported", "GroupMessaging", "NrOfRXPDO",
                    "NrOfTXPDO", "LSS_Supported"}
    assert "StorageLocation=" not in text
    assert "\nUnit=" not in text
    assert re.search(r"^PDOMapping=(?!0$|1$)", text, re.MULTILINE) is None


def test_rev15_every_mapped_object_is_pdo_mappable() -> None:
    for device in DEVICES:
        description = _description(device)
        od: Any = import_od(str(shipped_eds(description)), description.default_node_id)
        for index in range(0x1600, 0x1800):
            if index in od:
                for var in od[index].values():
                    if var.subindex:
                        target = od[var.default >> 16]
                        mapped = target[(var.default >> 8) & 0xFF] if hasattr(
                            target, "subindices") else target
                        assert mapped.pdo_mappable, f"{device} {index:04X}sub{var.subindex}"
    text = shipped_eds(describe_device("keypad@1.5")).read_text()
    assert "PDOMapping=1" in text.split("[2003sub3]", 1)[1].split("\n\n", 1)[0]


def test_rev11_led_rpdos_built_from_the_eds_are_the_frame_the_keypad_acts_on() -> None:
    """A master that trusts the EDS mapping (python-canopen here) sends the packed 5-byte
    frame; the keypad twin lights what the master meant (errata P7)."""
    description = describe_device("keypad@1.1")
    node: Any = canopen.RemoteNode(0x15, str(shipped_eds(description)))
    canopen.Network().add_node(node)
    node.rpdo.read(from_od=True)
    led_on = node.rpdo[1]
    led_on.map[0].raw = 0x001  # red 1
    led_on.map[1].raw = 0x002  # green 2
    led_on.map[2].raw = 0x800  # blue 12
    keypad = KeypadTwin()
    keypad.power_on(0.0)
    keypad.advance(10.0)  # after the startup LED show
    keypad.receive(Frame(0x000, bytes([0x01, 0x15])), 10.0)
    keypad.receive(Frame(RPDO1 + 0x15, bytes(led_on.data)), 10.1)
    colours = {key["key"]: key["colour"] for key in keypad.snapshot()["keys"]}
    assert len(led_on.data) == 5
    assert (colours[1], colours[2], colours[12]) == ("red", "green", "blue")
    assert {k for k, c in colours.items() if c != "off"} == {1, 2, 12}
