"""A candump log without newlines refused at its first line in bounded memory by the fleet's
reader too (issue 18 item 6: every reader of a user's log bounds its lines), compressed or not
(issue 23: bounded memory whatever the file)."""

from __future__ import annotations

import gzip
import os
import tracemalloc
from collections.abc import Iterator
from pathlib import Path

import pytest

from blinkcan.fleet.sources import read_columns
from blinkcan.fleet.task import decode_file
from blinkcan.formats.columns import FrameColumns
from blinkcan.formats.log_source import MAX_LINE
from tests.fleet.logs import fleet_traffic, write_log
from tests.formats.test_log_sources import CANDUMP, _no_newline


def _peak_to_refuse(path: Path) -> int:
    """Bytes allocated at most while the fleet's reader refuses ``path``'s first line."""
    tracemalloc.start()
    try:
        with pytest.raises(ValueError, match=f"^line 1 is over {MAX_LINE} bytes: "
                                             "not a candump log$"):
            list(read_columns(path))
        return tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def test_a_candump_log_without_newlines_is_refused_in_bounded_memory(tmp_path: Path) -> None:
    peak = _peak_to_refuse(_no_newline(tmp_path / "huge.log", 24 << 20))
    assert peak < 2 << 20, f"{peak:,} bytes to refuse a 24 MB line"


def _zeros(path: Path, size: int) -> Path:
    """``size`` zero bytes compressed as ``path`` names: a few kilobytes (a zip bomb)."""
    chunk = bytes(1 << 20)
    if path.suffix == ".gz":
        with gzip.open(path, "wb") as stream:
            for _ in range(size >> 20):
                stream.write(chunk)
        return path
    import zstandard

    compressor = zstandard.ZstdCompressor().compressobj()
    with path.open("wb") as stream:
        for _ in range(size >> 20):
            stream.write(compressor.compress(chunk))
        stream.write(compressor.flush())
    return path


@pytest.mark.parametrize("suffix", [".gz", ".zst"])
def test_a_compressed_log_of_zeros_is_refused_in_bounded_memory(tmp_path: Path,
                                                                suffix: str) -> None:
    path = _zeros(tmp_path / f"bomb.log{suffix}", 64 << 20)
    assert path.stat().st_size < 1 << 20
    peak = _peak_to_refuse(path)
    assert peak < 4 << 20, f"{peak:,} bytes to refuse 64 MiB of zeros in {suffix}"


def test_each_frame_keeps_its_channel(tmp_path: Path) -> None:
    path = tmp_path / "two.log"
    path.write_text(CANDUMP.replace("can0", "can1", 1))
    assert [c for block in read_columns(path) for c in block.channels] == ["can1", "can0"]


def test_a_fifo_is_named_as_one_not_as_missing(tmp_path: Path) -> None:
    """`decode ff --parquet lake` said "no such file: .../ff" for a FIFO that is there."""
    fifo = tmp_path / "ff"
    os.mkfifo(fifo)
    with pytest.raises(ValueError, match=f"^{fifo} is a FIFO: --parquet reads regular files "
                                         r"only \(decode without --parquet reads a stream\)$"):
        list(read_columns(fifo))
    result = decode_file(fifo, str(tmp_path / "lake"))
    assert (result.status, result.error) == ("failed", f"{fifo} is a FIFO: --parquet reads "
                                             "regular files only (decode without --parquet "
                                             "reads a stream)")


def test_a_compressed_log_is_decompressed_at_most_so_far(tmp_path: Path) -> None:
    """A .asc.gz was decompressed whole into /tmp, however large it came out."""
    path = write_log(tmp_path / "unit.asc.gz", fleet_traffic(taps=1))
    scratch = tmp_path / "scratch"
    with pytest.raises(ValueError, match=f"^{path} decompresses to over 1,000 bytes, the most "
                                         "a compressed log other than candump is decompressed "
                                         r"to \(on disk, to be read\): refused$"):
        list(read_columns(path, scratch=str(scratch), max_decompressed=1000))
    assert list(scratch.iterdir()) == []
    assert sum(len(block) for block in read_columns(path)) == len(fleet_traffic(taps=1))


def test_a_compressed_log_is_decompressed_in_the_attempt_folder(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Decompressed into /tmp, the file was left there when the run was killed: in the
    run's attempt folder, the next run's recovery removes it."""
    path = write_log(tmp_path / "unit.asc.gz", fleet_traffic(taps=1))
    out = tmp_path / "lake"
    seen: list[list[Path]] = []

    def spying(source: str, scratch: str) -> Iterator[FrameColumns]:
        for block in read_columns(source, scratch=scratch):
            seen.append(list(Path(scratch).glob(".blinkcan-*.asc")))
            yield block

    monkeypatch.setattr("blinkcan.fleet.task.read_columns", spying)
    result = decode_file(path, str(out))
    assert (result.status, result.frames) == ("decoded", len(fleet_traffic(taps=1)))
    [[decompressed], *_] = seen
    assert decompressed.parent.parent == out / "_blinkcan" / "tmp"
    assert not decompressed.exists()
