"""The EDS ``blinkcan export eds`` writes for every registered case loads in the tools CANopen
users read EDS files with (issue 19): python-canopen (no warning), CanFestival's objdictgen (its
validator finds nothing and it generates its C dictionary from it) and eds-utils (nothing but
the documented deliberate findings, and it generates a CANopenNode dictionary from it). A
python-canopen ``RemoteNode`` reading the PDOs of a live twin with this EDS is in
test_models.py.

Left out on purpose: objdictgen's JSON export. Its EDS reader adds a user mapping to every
standard object (1000h, 1018h, ...) beside its built-in one, and its JSON writer then refuses
any object with two ("Contains uexpected number of groups (2)"), for any EDS: a three-object
EDS written by hand fails the same way (objdictgen 3.5.5)."""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

import pytest
from canopen.objectdictionary import import_od
from click.testing import CliRunner

from blinkcan.cli.main import cli
from tests.conformance.cases import Case, cases
from tests.formats.test_eds_tools import DELIBERATE


def _exported(case: Case, tmp_path: Path) -> Path:
    """The case's EDS as ``blinkcan export eds`` writes it."""
    path = tmp_path / "device.eds"
    result = CliRunner().invoke(cli, ["export", "eds", case.spec, "--quirks", case.quirks,
                                      "-o", str(path)])
    assert result.exit_code == 0, result.output
    return path


def _warnings(caplog: pytest.LogCaptureFixture) -> list[str]:
    return [record.getMessage() for record in caplog.records
            if record.levelno >= logging.WARNING]


@pytest.mark.parametrize("case", cases("eds-python-canopen"))
def test_python_canopen_reads_the_exported_eds_without_a_warning(
        case: Case, tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    if not case.canopen:  # a keypad in J1939 mode answers no SDO: its DBC is what tools read
        return
    path = _exported(case, tmp_path)
    with caplog.at_level(logging.WARNING):
        od: Any = import_od(str(path), case.model.default_node_id)
    assert _warnings(caplog) == []
    table = case.description.table
    assert {(e.index, e.subindex) for e in table} <= {
        (var.index, var.subindex) for obj in od.values()
        for var in (obj.values() if hasattr(obj, "subindices") else [obj])}


@pytest.mark.parametrize("case", cases("eds-objdictgen"))
def test_objdictgen_validates_the_exported_eds_and_generates_its_c_dictionary(
        case: Case, tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    if not case.canopen:
        return
    objdictgen = pytest.importorskip("objdictgen", reason="objdictgen (dev extra) is missing")
    path = _exported(case, tmp_path)
    with caplog.at_level(logging.WARNING):
        node: Any = objdictgen.LoadFile(str(path))
        node.Validate()
        node.DumpFile(str(tmp_path / "device.c"), filetype="c")
    assert _warnings(caplog) == []
    assert (tmp_path / "device.c").stat().st_size > 0
    assert node.GetEntry(0x1000) == case.description.table["device_type"].default


@pytest.mark.parametrize("case", cases("eds-eds-utils"))
def test_eds_utils_finds_only_the_deliberate_and_generates_canopennode_files(
        case: Case, tmp_path: Path) -> None:
    if not case.canopen:
        return
    read_eds = pytest.importorskip("eds_utils.core.file_io.read_eds",
                                   reason="eds-utils (dev extra) is missing")
    canopennode = pytest.importorskip("eds_utils.core.file_io.write_canopennode")
    path = _exported(case, tmp_path)
    eds, findings = read_eds.read_eds(str(path))
    description = case.description
    wanted = DELIBERATE.get((description.model, description.generation), set())
    assert {finding.removeprefix("AUTO-FIXED: ") for finding in findings} == wanted
    out = tmp_path / "canopennode"
    out.mkdir()
    canopennode.write_canopennode(eds, dir_path=str(out))
    assert sorted(p.name for p in out.iterdir()) == ["OD.c", "OD.h"]
