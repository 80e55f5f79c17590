"""Hostile logs (issue 18 item 6): a file without newlines, /dev/zero, a FIFO, a directory, a
socket. Every reader of a user's log (decode, convert, monitor --log, golden traces) opens it
through one opener (formats/log_source.py): what the path is is named, a stream is read as
one, and a line is never longer than MAX_LINE, so memory stays bounded whatever it holds."""

from __future__ import annotations

import contextlib
import os
import socket
import sys
import threading
import tracemalloc
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from blinkcan.formats.log_source import MAX_LINE
from blinkcan.formats.logs import FrameWriter, LogError, read_log, read_messages
from blinkcan.formats.unreadable import UnreadableLine
from blinkcan.protocol import Frame

CANDUMP = "(1700000000.000100) can0 715#05\n(1700000000.000200) can0 18FF2115#0102 R\n"
_READERS: dict[str, Callable[[Path], list[object]]] = {
    "read_log": lambda path: list(read_log(path)),
    "read_messages": lambda path: list(read_messages(path)),
}
_KINDS = {".log": "a candump", ".asc": "an ASC", ".trc": "a TRC", ".csv": "a CSV"}


def _no_newline(path: Path, size: int) -> Path:
    block = b"0" * (1 << 20)
    with path.open("wb") as stream:
        for _ in range(size >> 20):
            stream.write(block)
    return path


@pytest.mark.parametrize("reader", sorted(_READERS))
@pytest.mark.parametrize("suffix", sorted(_KINDS))
def test_a_text_log_without_newlines_is_refused_at_line_one_in_bounded_memory(
        tmp_path: Path, suffix: str, reader: str) -> None:
    path = _no_newline(tmp_path / f"huge{suffix}", 24 << 20)
    tracemalloc.start()
    try:
        with pytest.raises(LogError) as refused:
            _READERS[reader](path)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert str(refused.value) == (f"{path}: line 1 is over {MAX_LINE} bytes: "
                                  f"not {_KINDS[suffix]} log")
    assert peak < 2 << 20, f"{peak:,} bytes to refuse a 24 MB line"


def test_the_long_line_is_named_where_it_is(tmp_path: Path) -> None:
    path = tmp_path / "late.log"
    path.write_text(CANDUMP * 40_000 + "(1.0) can0 715#" + "00" * MAX_LINE + "\n" + CANDUMP)
    for items in ([item for _, item in read_log(path)],
                  list(read_messages(path, unreadable=True))):
        assert len(items) == 80_003  # the frames after it are read (issue 23)
        long = items[80_000]
        assert isinstance(long, UnreadableLine)
        assert long.number == 80_001
        assert str(long).startswith("line 80001: '(1.0) can0 715#0000")
        assert f"is {15 + 2 * MAX_LINE:,} characters long, over the {MAX_LINE}" in str(long)
    with pytest.raises(LogError, match="line 80001: '"):
        list(read_messages(path))  # the strict reader names it


@pytest.mark.parametrize("reader", sorted(_READERS))
def test_dev_zero_ends_with_the_line_bound_directly_or_through_a_symlink(
        tmp_path: Path, reader: str) -> None:
    if not Path("/dev/zero").is_char_device():
        pytest.skip("no /dev/zero here")
    link = tmp_path / "zero.log"
    link.symlink_to("/dev/zero")
    for path in (link, Path("/dev/zero")):
        with pytest.raises(LogError, match=f"^{path}: line 1 is over {MAX_LINE} bytes: "
                                           "not a candump log$"):
            _READERS[reader](path)


@contextlib.contextmanager
def _fifo(path: Path, data: bytes) -> Iterator[Path]:
    """A FIFO at ``path`` that a thread fills with ``data`` once a reader opens it."""
    os.mkfifo(path)

    def fill() -> None:
        with path.open("wb") as stream:  # blocks until the reader opens it
            stream.write(data)

    writer = threading.Thread(target=fill, daemon=True)
    writer.start()
    try:
        yield path
    finally:
        if writer.is_alive():  # nobody read it: open it once so the writer ends
            with contextlib.suppress(OSError):
                os.close(os.open(path, os.O_RDONLY | os.O_NONBLOCK))
        writer.join(10)


@pytest.mark.parametrize("name", ["bus.log", "bus"])
def test_a_fifo_is_read_as_a_candump_stream(tmp_path: Path, name: str) -> None:
    with _fifo(tmp_path / name, CANDUMP.encode()) as path:
        assert [(t, f) for t, f in read_log(path)] == [
            (1700000000.0001, Frame(0x715, b"\x05")),
            (1700000000.0002, Frame(0x18FF2115, b"\x01\x02", extended=True))]
    with _fifo(tmp_path / f"again-{name}", CANDUMP.encode()) as path:
        messages = list(read_messages(path))
    assert [(m.arbitration_id, bytes(m.data), m.is_rx) for m in messages] == [
        (0x715, b"\x05", True), (0x18FF2115, b"\x01\x02", True)]


def test_a_pcap_fifo_is_read_as_a_stream(tmp_path: Path) -> None:
    capture = tmp_path / "capture.pcap"
    with FrameWriter(capture) as writer:
        writer.write(1.5, Frame(0x715, b"\x05"))
    with _fifo(tmp_path / "live.pcap", capture.read_bytes()) as path:
        assert list(read_log(path)) == [(1.5, Frame(0x715, b"\x05"))]


def test_what_is_not_a_log_is_named(tmp_path: Path) -> None:
    with pytest.raises(LogError, match=f"^{tmp_path} is a directory, not a log file$"):
        list(read_log(tmp_path))
    dangling = tmp_path / "gone.log"
    dangling.symlink_to("nowhere.log")
    with pytest.raises(LogError, match=r"no such file: .*gone\.log \(a symlink to nowhere\.log"):
        list(read_messages(dangling))
    with socket.socket(socket.AF_UNIX) as server:
        server.bind(str(tmp_path / "s.log"))
        with pytest.raises(LogError, match=r"s\.log is a socket, not a log file$"):
            list(read_log(tmp_path / "s.log"))
    os.mkfifo(tmp_path / "bus.blf")
    with pytest.raises(LogError, match=r"bus\.blf is a FIFO: a \.blf log is read from a "
                                       "regular file only"):
        list(read_messages(tmp_path / "bus.blf"))
    blocks = [p for p in Path("/dev").glob("loop*") if p.is_block_device()] if sys.platform \
        == "linux" else []
    if blocks:
        with pytest.raises(LogError, match="is a block device, not a log file"):
            list(read_log(blocks[0]))
