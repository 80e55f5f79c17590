"""The fleet's fast path (formats/candump_columns.py: blocks of plain candump lines read by
Arrow, other ECUs' frames filled in per identifier, fleet/frames.py) gives the dataset the
line-by-line path gives, row for row and value for value: on a realistic log with every
model's traffic, where the decoder learns a model mid-block, and on random mixes of plain
and odd lines (which send their block down the line-by-line path)."""

from __future__ import annotations

import math
from functools import partial
from pathlib import Path
from typing import Any

import can
import pyarrow.parquet as pq
import pytest
from benchmarks.realistic_log import device_nodes, realistic_traffic, write_candump
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from blinkcan.decode.nodes import ModelsByNode
from blinkcan.devices.registry import (
    default_descriptions,
    describe_device,
    identify,
    models,
    sole_senders,
)
from blinkcan.fleet import task
from blinkcan.fleet.sources import read_columns
from blinkcan.fleet.task import FileResult
from blinkcan.formats.columns import ArrowColumns
from blinkcan.protocol import Frame
from blinkcan.protocol.cob import HEARTBEAT, SDO_RX, SDO_TX
from tests.fleet.logs import EPOCH, candump_lines, fleet_traffic


def _decode(log: Path, out: Path, arrow: bool, block_chars: int, rows_per_group: int,
            devices: ModelsByNode | None) -> tuple[FileResult, dict[str, Any]]:
    """The file decoded by one path: its result, and each Parquet file's rows and row
    groups."""
    reader = partial(read_columns, arrow=arrow, block_chars=block_chars)
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(task, "read_columns", reader)
        result = task.decode_file(log, str(out), force=True, devices=devices,
                                  rows_per_group=rows_per_group)
    files = {}
    for relative in result.outputs:
        parquet = pq.ParquetFile(out / relative)
        files[relative] = (parquet.read().to_pylist(), [
            parquet.metadata.row_group(n).num_rows for n in range(parquet.num_row_groups)])
    return result, files


def _shown(other: object) -> object:
    """A python-can message as its values (a message equals only itself)."""
    if isinstance(other, can.Message):
        return (other.timestamp, other.arbitration_id, other.is_extended_id,
                other.is_remote_frame, other.is_error_frame, other.is_fd, other.dlc,
                bytes(other.data), other.channel)
    return other


def _frames(log: Path, arrow: bool, block_chars: int) -> list[tuple[Any, ...]]:
    """The reader's frames, each as (time, channel, id, flag, data, what is not a frame)."""
    found: list[tuple[Any, ...]] = []
    try:
        for block in read_columns(log, arrow=arrow, block_chars=block_chars):
            found += [(t, c, i, e, d, _shown(block.others.get(n))) for n, (t, c, i, e, d) in
                      enumerate(zip(block.times, block.channels, block.ids, block.extended,
                                    block.data, strict=True))]
    except ValueError as error:  # no line is a frame: the same error either way
        found.append((str(error),))
    return found


def assert_same_dataset(log: Path, tmp_path: Path, block_chars: int, rows_per_group: int,
                        devices: ModelsByNode | None = None) -> dict[str, Any]:
    """Both paths give the same frames, the same result and the same files; the files."""
    assert _frames(log, True, block_chars) == _frames(log, False, block_chars)
    fast = _decode(log, tmp_path / "fast", True, block_chars, rows_per_group, devices)
    lines = _decode(log, tmp_path / "lines", False, block_chars, rows_per_group, devices)
    assert fast[0] == lines[0]
    assert fast[1].keys() == lines[1].keys()
    for name, (rows, groups) in fast[1].items():
        assert groups == lines[1][name][1], name
        for number, (row, other) in enumerate(zip(rows, lines[1][name][0], strict=True)):
            assert row == other, (name, number)
    return fast[1]


@pytest.mark.parametrize("rows_per_group", [7, 1_000])
def test_a_realistic_log_of_every_model_reads_the_same_both_ways(tmp_path: Path,
                                                                 rows_per_group: int) -> None:
    """Every model's traffic and other ECUs' (realistic_log.py), row groups full inside a
    block (in a run of other ECUs' frames, or at a frame decoded) and at its end."""
    log = tmp_path / "unit.log"
    write_candump(log, realistic_traffic(6_000))
    assert any(isinstance(b, ArrowColumns) for b in read_columns(log, block_chars=4_000))
    files = assert_same_dataset(log, tmp_path, 4_000, rows_per_group, device_nodes())
    assert len(files) > 1
    assert all(len(groups) > 1 for _, groups in files.values())


def test_the_fleet_logs_read_the_same_both_ways(tmp_path: Path) -> None:
    log = tmp_path / "fleet.log"
    log.write_text("".join(candump_lines(fleet_traffic())))
    assert_same_dataset(log, tmp_path, 3_000, 500)


def _device_type(model: Any) -> int:
    device_type = describe_device(model.name).table["device_type"].default
    assert isinstance(device_type, int)
    return device_type


def _identity(node: int, model: Any) -> list[Frame]:
    """A host's upload of 1000h (device type) and the node's expedited answer (CiA 301
    §7.2.4.3.6)."""
    device_type = _device_type(model)
    return [Frame(0x600 + node, bytes((0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0))),
            Frame(0x580 + node, bytes((0x43, 0x00, 0x10, 0x00)) + device_type.to_bytes(
                4, "little"))]


def _unused_base() -> int:
    """A PDO COB-ID base no registered model uses: a node's frame there is another ECU's
    (a frame only one model sends would name the node's model: decode/decoder.py)."""
    used = {layout.cob_base for d in default_descriptions() for layout in d.pdos}
    return next(base for base in range(0x180, HEARTBEAT, 0x80)
                if base not in used | {SDO_TX, SDO_RX})


def _learned_mid_block(tmp_path: Path, node: int, teaching: list[Frame]) -> dict[str, Any]:
    """Another ECU's frames, some at ``node``, with ``teaching`` at 1.495 s: the partitions
    of the dataset (the same both ways) by their first directory, and the time taught."""
    foreign = (Frame(_unused_base() + node, bytes(8)), Frame(0x7E0, b"\x02\x01\x0c"),
               Frame(0x18FEF100, bytes(8), extended=True))
    traffic = [(EPOCH + n * 0.01, foreign[n % len(foreign)]) for n in range(300)]
    traffic[150:150] = [(EPOCH + 1.495, frame) for frame in teaching]
    log = tmp_path / "learn.log"
    log.write_text("".join(candump_lines(traffic)))
    for block_chars in (1_500, 2_000, 2_500):  # the teaching frame inside a block read whole
        files = assert_same_dataset(log, tmp_path / str(block_chars), block_chars, 1 << 16)
    return {name.split("/")[0]: rows for name, (rows, _) in files.items()}


def _assert_learned_at(partitions: dict[str, Any], node: int, model: str) -> None:
    """The node's frames before 1.495 s are of no model, those after of ``model``."""
    learning = EPOCH + 1.495
    before = [r["time"].timestamp() for r in partitions["model=unknown"] if r["node"] == node]
    after = [r["time"].timestamp() for r in partitions[f"model={model}"] if r["node"] == node]
    assert before
    assert after
    assert max(before) <= learning <= min(after) < max(after)


@pytest.mark.parametrize("model", models(), ids=lambda model: model.name)
def test_a_model_learned_from_a_frame_only_it_sends_names_the_frames_after_it(
        tmp_path: Path, model: Any) -> None:
    """As from identity: a PDO only this model sends (sole_senders) names the node's model
    mid-block, once the node is heard as a CANopen node (its boot-up just after: another
    ECU's frame alone names nothing); the fast path and the line-by-line one give the same
    rows."""
    node = 0x3A
    bases = [base for base, sender in sole_senders().items() if sender.model == model.name]
    if not bases:
        pytest.skip(f"{model.name} sends no frame another model does not")
    teaching = [Frame(bases[0] + node, bytes(8)), Frame(0x700 + node, b"\x00")]
    partitions = _learned_mid_block(tmp_path, node, teaching)
    _assert_learned_at(partitions, node, model.name)


@pytest.mark.parametrize("model", models(), ids=lambda model: model.name)
def test_a_model_learned_mid_block_names_the_frames_after_it(tmp_path: Path,
                                                             model: Any) -> None:
    """Another ECU's frames of a node before and after the node's identity names its model:
    the fast path fills them in per identifier, but not past the frame that teaches it."""
    node = 0x3A
    partitions = _learned_mid_block(tmp_path, node, _identity(node, model))
    learned = identify(device_type=_device_type(model))
    assert learned is not None
    _assert_learned_at(partitions, node, learned.model)


# -- random mixes --------------------------------------------------------------------------

#: identifiers the decoder knows (the default keypad's and Keybox's, NMT, SYNC, SDO) and
#: other ECUs'
_IDS = (0x000, 0x080, 0x195, 0x215, 0x595, 0x615, 0x715, 0x1A0, 0x220, 0x2A0, 0x5A0, 0x620,
        0x720, 0x181, 0x7E8, 0x3FF, 0x7FF)
_EXTENDED = (0x0CF00400, 0x18FEF100, 0x18EF2180, 0x18EF8021, 0x1CFFFF00, 0x00000001)
_ODD = ("", "   ", "# a comment", "(1700000000.5) can0 195#R", "(1700000000.5) can0 123##1aabb",
        "(1700000000.5) can0 20000080#0000000000000000", "(1700000000.5) can0 12#00",
        "(nan) can0 123#00", "(inf) can0 123#00", "can0 123#00", "(1700000000.5) can0 123#0",
        "(1700000000.5) can0 123#001122334455667788", "(1700000000.5)\tcan0 123#00",
        "(1700000000.5) can0 123#00 R", "(1700000000.5) can0 123#00 ", "(1700000000.5) can0 800#00",
        "(1700000000.5) can0 3FFFFFFF#00", "(1700000000.5) can0 0000123#00", "(17000) can0",
        "(1700000000.5) can0 7fF#aBcD", "(-1.5) can0 123#00", "(1e3) can0 123#00", "garbage",
        "(1x.5) can0 123#00", "(inf.5) can0 123#00", "(1700000000.5) can0 123#" + "00" * 2100)


@st.composite
def _plain_line(draw: st.DrawFn) -> str:
    seconds = draw(st.integers(0, 10**12 - 1))
    fraction = draw(st.text("0123456789", min_size=1, max_size=9))
    channel = draw(st.sampled_from(("can0", "can1", "vcan12", "1")))
    if draw(st.booleans()):
        ident = f"{draw(st.sampled_from(_IDS)):03X}"
    else:
        ident = f"{draw(st.sampled_from(_EXTENDED)):08X}"
    data = draw(st.binary(max_size=8)).hex()
    if draw(st.booleans()):
        ident, data = ident.lower(), data.upper()
    return f"({seconds}.{fraction}) {channel} {ident}#{data}"


@given(lines=st.lists(st.one_of(_plain_line(), _plain_line(), _plain_line(),
                                st.sampled_from(_ODD)), max_size=60),
       newline=st.booleans(), block_chars=st.integers(40, 600),
       rows_per_group=st.integers(1, 40))
@settings(max_examples=40, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
def test_random_mixes_of_plain_and_odd_lines_read_the_same_both_ways(
        tmp_path_factory: pytest.TempPathFactory, lines: list[str], newline: bool,
        block_chars: int, rows_per_group: int) -> None:
    folder = tmp_path_factory.mktemp("mix")
    log = folder / "mix.log"
    known = [f"(1.5) can0 {ident:03X}#00" for ident in _IDS] + \
        [f"(1.5) can0 {ident:08X}#00" for ident in _EXTENDED]  # seen before the mix
    log.write_bytes(("\n".join(known + lines) + ("\n" if newline else "")).encode())
    assert_same_dataset(log, folder, block_chars, rows_per_group)


def test_a_time_reads_as_python_reads_it(tmp_path: Path) -> None:
    """Arrow's decimal-to-double gives Python's float() to the last bit."""
    stamps = ["1700000000.000001", "0.1", "999999999999.999999999", "1780271940.0001",
              "123456789012.123456789", "4503599627370495.5"[:21], "0.000000001"]
    log = tmp_path / "times.log"
    log.write_text("".join(f"({s}) can0 123#00\n" for s in stamps
                           if len(s.split(".")[0]) <= 12))
    [block] = list(read_columns(log))
    assert isinstance(block, ArrowColumns)
    assert block.times == [float(s) for s in stamps if len(s.split(".")[0]) <= 12]
    assert all(math.isfinite(t) for t in block.times)
