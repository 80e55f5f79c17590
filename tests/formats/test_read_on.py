"""One bad line never costs the rest of a capture (issue 23: nothing a user recorded is lost):
in every text format (candump, ASC, TRC, CSV: python-can's readers for the last three) a line
a reader cannot read, or one over MAX_LINE, is an unreadable line in its place, named with its
number, and every frame after it is read; convert writes them and exits 1 saying how many."""

from __future__ import annotations

import gzip
import struct
import tracemalloc
from collections.abc import Callable, Sequence
from pathlib import Path

import pytest
from click.testing import CliRunner

from blinkcan.cli.main import cli
from blinkcan.fleet.sources import read_columns
from blinkcan.formats.log_source import MAX_LINE
from blinkcan.formats.logs import FrameWriter, LogError, read_log, read_messages
from blinkcan.formats.unreadable import UnreadableLine
from blinkcan.protocol import Frame

TEXT_FORMATS = [".log", ".asc", ".trc", ".csv"]
COUNT = 3000  # frames: more than one 64 KiB read chunk in every format
WHERE = ["second", "middle", "last"]


def _capture(tmp_path: Path, suffix: str) -> tuple[Path, list[str], list[int]]:
    """A capture of COUNT frames written by FrameWriter: its path, its lines, the index of
    each frame's line (in order)."""
    path = tmp_path / f"capture{suffix}"
    with FrameWriter(path) as writer:
        for n in range(COUNT):
            writer.write(1_700_000_000 + n / 100, Frame(0x195, bytes([n % 256, n // 256, 7])))
    lines = path.read_text().split("\n")
    frame_lines = [i for i, line in enumerate(lines) if "195" in line or "AAc" in line
                   or line.startswith("17000")]
    frame_lines = frame_lines[-COUNT:]
    assert len(frame_lines) == COUNT
    return path, lines, frame_lines


def _broken(line: str, suffix: str) -> str:
    """A frame line no reader reads: cut short, or (ASC, whose reader passes over a line it
    does not recognise as a frame: an event, a comment) a data byte that is not hex."""
    if suffix == ".asc":
        assert line.rstrip().endswith(" 07")
        return line.rstrip()[:-3] + " ZZ"
    return line[:14]


def _at(frame_lines: list[int], where: str) -> int:
    return {"second": 1, "middle": COUNT // 2, "last": COUNT - 1}[where]


def _payloads(items: Sequence[object]) -> list[int]:
    """The frame numbers (the first data byte and the second's 256s) of the frames read."""
    numbers = []
    for item in items:
        data = item.data if isinstance(item, Frame) else getattr(item, "data", None)
        if data is not None:
            numbers.append(data[0] + 256 * data[1])
    return numbers


def _read_everywhere(path: Path) -> dict[str, list[object]]:
    """What decode's reader, convert's reader and the fleet's read from ``path``."""
    return {
        "read_log": [item for _, item in read_log(path)],
        "read_messages": list(read_messages(path, unreadable=True)),
        "fleet": [block.others.get(row, Frame(block.ids[row], block.data[row]))
                  for block in read_columns(path) for row in range(len(block.times))],
    }


def _one_line_replaced(tmp_path: Path, suffix: str, where: str,
                       replace: Callable[..., str], *extra: str
                       ) -> tuple[int, str, dict[str, UnreadableLine]]:
    """A capture with the frame line at ``where`` replaced by ``replace(line, *extra)``, read by
    every reader: each must read every other frame and that line as one unreadable item in
    its place. Returns the line's index, its new text and each reader's unreadable item."""
    path, lines, frame_lines = _capture(tmp_path, suffix)
    index = _at(frame_lines, where)
    line_index = frame_lines[index]
    new = lines[line_index] = replace(lines[line_index], *extra)
    path.write_text("\n".join(lines))
    expected = [n for n in range(COUNT) if n != index]
    found: dict[str, UnreadableLine] = {}
    for reader, items in _read_everywhere(path).items():
        assert _payloads(items) == expected, reader
        [(position, unreadable)] = [(n, item) for n, item in enumerate(items)
                                    if isinstance(item, UnreadableLine)]
        assert position == index, reader
        assert isinstance(unreadable, UnreadableLine)
        assert unreadable.number == line_index + 1, reader
        found[reader] = unreadable
    return line_index, new, found


@pytest.mark.parametrize("where", WHERE)
@pytest.mark.parametrize("suffix", TEXT_FORMATS)
def test_a_bad_frame_line_is_named_in_its_place_and_reading_goes_on(
        tmp_path: Path, suffix: str, where: str) -> None:
    line_index, bad, found = _one_line_replaced(tmp_path, suffix, where, _broken, suffix)
    for reader, unreadable in found.items():
        assert unreadable.text == bad.rstrip("\r"), reader
        assert str(unreadable).startswith(f"line {line_index + 1}: "), reader


@pytest.mark.parametrize("where", WHERE)
@pytest.mark.parametrize("suffix", TEXT_FORMATS)
def test_a_line_over_max_line_is_one_unreadable_line_and_reading_goes_on(
        tmp_path: Path, suffix: str, where: str) -> None:
    _, long, found = _one_line_replaced(  # 200 KiB: over three read chunks
        tmp_path, suffix, where, lambda line: line + "0" * (MAX_LINE * 50))
    for reader, unreadable in found.items():
        assert unreadable.text == long[:MAX_LINE], reader  # a bounded prefix is kept
        assert f"is {len(long):,} characters long, over the {MAX_LINE}" in str(unreadable)


def test_a_long_line_is_read_past_in_bounded_memory(tmp_path: Path) -> None:
    path = tmp_path / "long.log"
    with path.open("w") as stream:
        stream.write("(1.0) can0 715#05\n")
        for _ in range(24):
            stream.write("0" * (1 << 20))
        stream.write("\n(2.0) can0 715#06\n")
    tracemalloc.start()
    try:
        items = [item for _, item in read_log(path)]
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert [type(item) for item in items] == [Frame, UnreadableLine, Frame]
    assert peak < 2 << 20, f"{peak:,} bytes to read past a 24 MB line"


@pytest.mark.parametrize("suffix", TEXT_FORMATS)
def test_a_first_line_over_max_line_is_no_log_of_the_format(tmp_path: Path,
                                                            suffix: str) -> None:
    # a binary file, /dev/zero: refused at once (an endless stream of zeros ends there)
    path = tmp_path / f"binary{suffix}"
    path.write_text("0" * (MAX_LINE + 1) + "\n")
    with pytest.raises(LogError, match=f"line 1 is over {MAX_LINE} bytes"):
        list(read_messages(path, unreadable=True))


@pytest.mark.parametrize("suffix", [".asc", ".trc", ".csv"])
def test_convert_keeps_the_frames_after_a_bad_line_and_exits_1_saying_how_many(
        tmp_path: Path, suffix: str) -> None:
    path, lines, frame_lines = _capture(tmp_path, suffix)
    for index in (10, 20):
        lines[frame_lines[index]] = _broken(lines[frame_lines[index]], suffix)
    path.write_text("\n".join(lines))
    target = tmp_path / "out.log"
    result = CliRunner().invoke(cli, ["convert", str(path), str(target)])
    assert result.exit_code == 1, result.output
    assert f"{COUNT - 2} frames written" in result.output
    assert (f"{path}: 2 lines could not be read (lines {frame_lines[10] + 1}, "
            f"{frame_lines[20] + 1})") in result.output
    assert len([f for _, f in read_log(target)]) == COUNT - 2


@pytest.mark.parametrize("suffix", [".asc", ".trc", ".csv"])
def test_a_gz_text_log_cut_short_keeps_the_frames_before_the_cut(tmp_path: Path,
                                                                 suffix: str) -> None:
    path, _, _ = _capture(tmp_path, suffix)
    packed = tmp_path / f"cut{suffix}.gz"
    whole = gzip.compress(path.read_bytes())
    packed.write_bytes(whole[: len(whole) // 2])
    items = list(read_messages(packed, unreadable=True))
    unreadable = [item for item in items if isinstance(item, UnreadableLine)]
    assert len(unreadable) == 1
    assert items[-1] is unreadable[0]
    assert "cut short" in str(unreadable[0])
    assert _payloads(items) == list(range(len(items) - 1))
    assert len(items) > 100


@pytest.mark.parametrize("suffix", [".trc", ".csv"])  # ASC's reader passes over such lines
def test_a_text_log_none_of_whose_lines_is_a_frame_is_refused(tmp_path: Path,
                                                              suffix: str) -> None:
    path = tmp_path / f"garbage{suffix}"
    path.write_text("garbage, not a frame\n" * 10)
    with pytest.raises(LogError):
        list(read_messages(path, unreadable=True))


def _pcap(tmp_path: Path, count: int = 20) -> tuple[Path, bytes]:
    path = tmp_path / "capture.pcap"
    with FrameWriter(path) as writer:
        for n in range(count):
            writer.write(1_700_000_000 + n / 100, Frame(0x195, bytes([n, 0, 7])))
    return path, path.read_bytes()


_PCAP_HEADER, _PACKET = 24, 16 + 16  # a classic frame's packet: its header and 16 bytes


def test_a_pcap_packet_that_is_no_frame_is_named_in_its_place_and_reading_goes_on(
        tmp_path: Path) -> None:
    path, data = _pcap(tmp_path)
    at = _PCAP_HEADER + 5 * _PACKET + 16  # packet 6's CAN id: a standard one over 7FFh
    path.write_bytes(data[:at] + struct.pack(">I", 0x7FF + 1) + data[at + 4:])
    for reader, items in _read_everywhere(path).items():
        assert _payloads(items) == [n for n in range(20) if n != 5], reader
        unreadable = items[5]
        assert isinstance(unreadable, UnreadableLine), reader
        assert str(unreadable) == "packet 6: standard identifier 800h is over 7FFh", reader
        assert unreadable.text == data[_PCAP_HEADER + 5 * _PACKET:][:16].hex() + \
            "00000800" + data[at + 4:][:12].hex()


@pytest.mark.parametrize(("cut", "reason"), [
    (3, "packet 20: truncated CAN frame: the capture ends there, cut off"),
    (_PACKET - 8, "packet 20: truncated header: the capture ends there, cut off"),
])
def test_a_pcap_cut_off_keeps_every_frame_before_the_cut(tmp_path: Path, cut: int,
                                                         reason: str) -> None:
    path, data = _pcap(tmp_path)
    path.write_bytes(data[:-cut])
    for reader, items in _read_everywhere(path).items():
        assert _payloads(items) == list(range(19)), reader
        assert str(items[-1]) == reason, reader


def test_a_pcap_packet_whose_length_is_no_frames_ends_the_reading_keeping_the_frames(
        tmp_path: Path) -> None:
    path, data = _pcap(tmp_path)
    at = _PCAP_HEADER + 10 * _PACKET + 8  # packet 11's included length
    path.write_bytes(data[:at] + struct.pack("<I", 1 << 20) + data[at + 4:])
    for reader, items in _read_everywhere(path).items():
        assert _payloads(items) == list(range(10)), reader
        assert str(items[-1]) == ("packet 11: 1048576 bytes, not a SocketCAN frame (16..72): "
                                  "the packets after it cannot be found"), reader
    result = CliRunner().invoke(cli, ["convert", str(path), str(tmp_path / "out.log")])
    assert result.exit_code == 1, result.output
    assert "10 frames written" in result.output
    assert f"Error: {path}: 1 packet could not be read (packet 11)" in result.output


def _compressed(text: bytes, suffix: str) -> bytes:
    if suffix == ".gz":
        return gzip.compress(text)
    import zstandard

    return zstandard.ZstdCompressor().compress(text)


@pytest.mark.parametrize("suffix", [".gz", ".zst"])
def test_a_compressed_candump_cut_inside_its_first_128_kib_says_what_it_kept(
        tmp_path: Path, suffix: str) -> None:
    # gzip gives every byte before the cut; zstd a block (up to 128 KiB of text) only whole,
    # so a .zst cut inside its first block has no line to give: the file is named, cut short
    lines = [f"({1700000000 + n / 1000:.6f}) can0 195#{n % 256:02X}{n * 7 % 65536:04X}\n"
             for n in range(20_000)]
    text = "".join(lines).encode()
    first_block = _compressed(text[: 128 << 10], ".zst")
    cut = tmp_path / f"cut.log{suffix}"
    cut.write_bytes(_compressed(text, suffix)[: len(first_block) // 2])
    if suffix == ".zst":
        with pytest.raises(ValueError, match=r"no line is a candump frame \(line 1: the "
                           "compressed file ends before any line of it could be "
                           r"decompressed: cut short \(a \.zst block"):
            list(read_columns(cut))
        return
    blocks = list(read_columns(cut))
    times = [time for block in blocks for time in block.times]
    [last] = [item for block in blocks for item in block.others.values()]
    assert isinstance(last, UnreadableLine)
    assert times[:-1] == [float(line[1:18]) for line in lines[: len(times) - 1]]
    assert len(times) > 100
    assert str(last).endswith("cut short")


def test_a_corrupt_blf_container_costs_its_own_frames_only(tmp_path: Path) -> None:
    path = tmp_path / "capture.blf"
    count = 12_000  # several of python-can's log containers (128 KiB of objects each)
    with FrameWriter(path) as writer:
        for n in range(count):
            writer.write(1_700_000_000 + n / 100, Frame(0x195, bytes([n % 256, n // 256, 7])))
    data = bytearray(path.read_bytes())
    containers = [at for at in range(len(data)) if data[at:at + 4] == b"LOBJ"]
    assert len(containers) >= 4
    middle = (containers[1] + containers[2]) // 2  # inside the second container's data
    data[middle:middle + 8] = bytes(8)
    path.write_bytes(bytes(data))
    for reader, items in _read_everywhere(path).items():
        numbers = _payloads(items)
        [(position, corrupt)] = [(n, item) for n, item in enumerate(items)
                                 if isinstance(item, UnreadableLine)]
        assert isinstance(corrupt, UnreadableLine)
        assert str(corrupt).startswith(f"byte {containers[2]}: the log container before this "
                                       "byte is corrupt"), reader
        assert numbers[:position] == list(range(position)), reader  # the first container's
        lost = numbers[position] - position  # the second container's, and one split after it
        assert 0 < lost < count // 4, reader
        assert numbers[position:] == list(range(position + lost, count)), reader
