"""``decode --parquet``'s summary counts every frame it wrote, for every format ``convert``
writes (a 1000-frame ASC log was reported as 999 frames while the dataset held all 1000):
the count said must be the frames in the dataset, one process or several."""

from __future__ import annotations

import gzip
import importlib.util
import re
from pathlib import Path

import pyarrow.dataset as ds
import pytest
import zstandard
from click.testing import CliRunner

from blinkcan.cli.main import cli
from blinkcan.formats.log_writers import WRITERS

FRAMES = 1000
#: formats convert writes that no reader reads back (python-can's Printer: for people)
WRITE_ONLY = {".txt"}
#: every format convert writes, pcap included
FORMATS = sorted({*WRITERS, ".pcap"} - WRITE_ONLY)
#: frames of every kind a .trc holds too (it refuses error frames), each one dataset row:
#: a heartbeat, another ECU's 11- and 29-bit frames, a remote frame, CAN FD with BRS
LINES = ["70C#05", "300#1122", "18FF0099#0102", "123#R", "125##1" + "00" * 12]


def _log(folder: Path) -> Path:
    log = folder / "source.log"
    log.write_text("".join(f"({1_700_000_000 + n * 0.001:.6f}) can{n % 2} "
                           f"{LINES[n % len(LINES)]}\n" for n in range(FRAMES)))
    return log


def _available(suffix: str) -> bool:
    return suffix != ".mf4" or importlib.util.find_spec("asammdf") is not None


def _converted(tmp_path: Path, suffix: str) -> Path:
    if not _available(suffix):
        pytest.skip(f"{suffix} needs asammdf")
    source = _log(tmp_path)
    if suffix == ".log":
        return source
    target = tmp_path / f"converted{suffix}"
    result = CliRunner().invoke(cli, ["convert", str(source), str(target)])
    assert result.exit_code == 0, result.output
    assert f"{FRAMES} frames written" in result.stderr
    return target


def _compressed(log: Path, compression: str) -> Path:
    """``log`` as ``log.gz`` / ``log.zst`` (the fleet reads both)."""
    if not compression:
        return log
    packed = log.with_name(log.name + compression)
    data = log.read_bytes()
    packed.write_bytes(gzip.compress(data) if compression == ".gz"
                       else zstandard.ZstdCompressor().compress(data))
    return packed


def _reported(stderr: str) -> int:
    said = re.search(r"decoded to \S+ \(([\d,]+) frames in", stderr)
    assert said is not None, stderr
    return int(said.group(1).replace(",", ""))


def _frames_in(dataset: Path) -> int:
    table = ds.dataset(dataset, format="parquet").to_table(columns=["kind", "time", "can_id"])
    assert "unreadable" not in table.column("kind").to_pylist()
    return len(set(zip(table.column("time").to_pylist(), table.column("can_id").to_pylist(),
                       strict=True)))


@pytest.mark.parametrize("compression", ["", ".gz", ".zst"])
@pytest.mark.parametrize("suffix", FORMATS)
def test_reported_frames_are_the_frames_written(tmp_path: Path, suffix: str,
                                                compression: str) -> None:
    log = _compressed(_converted(tmp_path, suffix), compression)
    out = tmp_path / "lake"
    result = CliRunner().invoke(cli, ["decode", str(log), "--parquet", str(out)])
    assert result.exit_code == 0, result.output
    assert _frames_in(out) == FRAMES
    assert _reported(result.stderr) == FRAMES


def test_reported_frames_with_workers(tmp_path: Path) -> None:
    """-j 2 counts each file when it is done: the same total."""
    logs = []
    for suffix in FORMATS:
        if _available(suffix):
            folder = tmp_path / suffix.lstrip(".")
            folder.mkdir()
            logs.append(str(_converted(folder, suffix)))
    out = tmp_path / "lake"
    result = CliRunner().invoke(cli, ["decode", *logs, "--parquet", str(out), "-j", "2"])
    assert result.exit_code == 0, result.output
    assert _reported(result.stderr) == FRAMES * len(logs)
