"""SQLite (``.db``) logs keep every frame written (issue 23): python-can's SqliteWriter stops
its thread after the batch it is writing and drops what is still queued, so a burst converted
to ``.db`` read back a sixth of its frames while ``convert`` said all were written."""

from __future__ import annotations

import sqlite3
from pathlib import Path

import can
from click.testing import CliRunner

from blinkcan.cli.main import cli
from blinkcan.formats.logs import FrameWriter, read_messages

FRAMES = 2885


def _candump(path: Path) -> Path:
    path.write_text("".join(f"({1700000000 + n / 1000:.6f}) can0 {0x700 + n % 64:03X}#"
                            f"{n % 256:02X}{n // 256:02X}\n" for n in range(FRAMES)))
    return path


def test_convert_to_db_keeps_every_frame(tmp_path: Path) -> None:
    source, target = _candump(tmp_path / "burst.log"), tmp_path / "burst.db"
    result = CliRunner().invoke(cli, ["convert", str(source), str(target)])
    assert result.exit_code == 0, result.output
    assert f"{FRAMES} frames written" in result.output
    back = list(read_messages(target))
    assert len(back) == FRAMES
    assert [(m.timestamp, m.arbitration_id, bytes(m.data)) for m in back] == \
        [(m.timestamp, m.arbitration_id, bytes(m.data)) for m in read_messages(source)]


def test_a_recorded_db_holds_each_flushed_frame_before_it_is_closed(tmp_path: Path) -> None:
    """A recording's rows are committed at each flush: a recorder killed after it keeps them."""
    writer = FrameWriter(tmp_path / "live.db", live=True)
    for n in range(3):
        writer.write_message(can.Message(timestamp=n, arbitration_id=0x715, data=b"\x05",
                                         is_extended_id=False))
    writer.flush()
    with sqlite3.connect(tmp_path / "live.db") as reader:
        assert reader.execute("SELECT count(*) FROM messages").fetchone() == (3,)
    writer.close()
    assert len(list(read_messages(tmp_path / "live.db"))) == 3
