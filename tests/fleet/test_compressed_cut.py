"""A compressed candump log cut short (a copy interrupted, a logger killed) is a failed file
that says so, for every compression the fleet reads: never a clean file with fewer frames."""

from __future__ import annotations

import gzip
from pathlib import Path

import pytest

from blinkcan.fleet import decode_files
from blinkcan.fleet.sources import read_columns
from tests.fleet.logs import Traffic, candump_lines, fleet_traffic


@pytest.fixture(scope="module")
def traffic() -> Traffic:
    return fleet_traffic()


def _compress(text: bytes, suffix: str) -> bytes:
    if suffix == ".gz":
        return gzip.compress(text)
    import zstandard

    return zstandard.ZstdCompressor().compress(text)


@pytest.mark.parametrize("suffix", [".gz", ".zst"])
def test_a_compressed_log_cut_short_fails_naming_the_cut(tmp_path: Path, traffic: Traffic,
                                                         suffix: str) -> None:
    whole = _compress("".join(candump_lines(traffic)).encode(), suffix)
    cut = tmp_path / f"cut.log{suffix}"
    cut.write_bytes(whole[: len(whole) // 2])
    with pytest.raises(EOFError):
        for _ in read_columns(cut):
            pass
    [result] = decode_files([cut], str(tmp_path / "lake"))
    assert result.status == "failed"
    assert "EOFError" in (result.error or "")


def test_a_zstd_log_of_several_frames_reads_whole(tmp_path: Path, traffic: Traffic) -> None:
    lines = list(candump_lines(traffic))
    half = len(lines) // 2
    log = tmp_path / "appended.log.zst"
    log.write_bytes(_compress("".join(lines[:half]).encode(), ".zst")
                    + _compress("".join(lines[half:]).encode(), ".zst"))
    assert sum(len(block) for block in read_columns(log)) == len(lines)
