"""A compressed candump log cut short (a copy interrupted, a logger killed) keeps every frame
before the cut, for every compression the fleet reads (and decode's .gz), and says where it was
cut (the last line, whole or not, may have been cut: it is an unreadable line): never a clean
file with fewer frames, and never a failed file whose frames are all lost (issue 23)."""

from __future__ import annotations

import gzip
import io
from pathlib import Path

import pytest

from blinkcan.fleet import decode_files
from blinkcan.fleet.sources import read_columns
from blinkcan.formats.candump import read_candump
from blinkcan.formats.log_source import DecompressedText
from blinkcan.formats.logs import read_log
from blinkcan.formats.unreadable import UnreadableLine
from blinkcan.protocol import Frame
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
def test_a_compressed_log_cut_short_keeps_the_frames_before_the_cut(
        tmp_path: Path, suffix: str) -> None:
    # over a few of zstd's 128 KiB blocks (a block is decompressed only whole), each line new
    lines = [f"({1700000000 + n / 1000:.6f}) can0 195#{n % 256:02X}{n // 256 % 256:02X}\n"
             for n in range(40_000)]
    whole = _compress("".join(lines).encode(), suffix)
    cut = tmp_path / f"cut.log{suffix}"
    cut.write_bytes(whole[: len(whole) // 2])
    blocks = list(read_columns(cut))
    times = [time for block in blocks for time in block.times]
    [last] = [item for block in blocks for item in block.others.values()
              if isinstance(item, UnreadableLine)]
    kept = len(times) - 1
    assert kept > len(lines) // 4  # most of what was decompressed before the cut
    assert times[:kept] == [float(line.split()[0][1:-1]) for line in lines[:kept]]
    assert last.cut_off
    assert last.number == kept + 1
    assert lines[kept].startswith(last.text)
    assert str(last).endswith("is where the compressed file ends, before its compressed "
                              "stream does: cut short")
    [result] = decode_files([cut], str(tmp_path / "lake"))
    assert (result.status, result.frames, result.unreadable) == ("decoded", kept, 1)
    assert result.cut_off == str(last)
    if suffix == ".gz":  # decode and convert read .gz too
        assert [t for t, item in read_log(cut) if not isinstance(item, UnreadableLine)] == \
            times[:kept]


class _CutAfter(io.BufferedIOBase):
    """A decompressor that gives ``data`` and then finds its compressed file cut short."""

    def __init__(self, data: bytes) -> None:
        self._data = data

    def readable(self) -> bool:
        return True

    def read1(self, size: int = -1) -> bytes:
        if not self._data:
            raise EOFError("Compressed file ended before the end-of-stream marker was reached")
        chunk, self._data = self._data[:size], self._data[size:]
        return chunk


def test_a_cut_at_a_line_end_is_still_said() -> None:
    # every line whole (a newline ends each), yet the file was cut short: the cut is named
    text = DecompressedText(_CutAfter(b"(1.0) can0 715#05\n(2.0) can0 715#0102\n"), "utf-8",
                            "surrogateescape")
    items = [item for _, item in read_candump(text)]
    assert items[:2] == [Frame(0x715, b"\x05"), Frame(0x715, b"\x01\x02")]
    [cut] = items[2:]
    assert isinstance(cut, UnreadableLine)
    assert (cut.number, cut.text, cut.cut_off) == (3, "", True)
    assert str(cut) == "line 3: there the compressed file ends, before its compressed stream " \
        "does: cut short"
    # a last line without its newline may have been cut inside its data ('#0102' of
    # '#010203'): it is no frame
    text = DecompressedText(_CutAfter(b"(1.0) can0 715#05\n(2.0) can0 715#0102"), "utf-8",
                            "surrogateescape")
    items = [item for _, item in read_candump(text)]
    assert items[0] == Frame(0x715, b"\x05")
    assert isinstance(items[1], UnreadableLine)
    assert items[1].text == "(2.0) can0 715#0102"
    assert items[1].time == 2.0
    assert len(items) == 2


def test_a_zstd_log_of_several_frames_reads_whole(tmp_path: Path, traffic: Traffic) -> None:
    lines = list(candump_lines(traffic))
    half = len(lines) // 2
    log = tmp_path / "appended.log.zst"
    log.write_bytes(_compress("".join(lines[:half]).encode(), ".zst")
                    + _compress("".join(lines[half:]).encode(), ".zst"))
    assert sum(len(block) for block in read_columns(log)) == len(lines)
