"""Hostile logs on the command line (issue 18 item 6): ``decode -`` and a FIFO are streams,
a file without newlines or /dev/zero is one line naming the file, in bounded memory."""

from __future__ import annotations

import os
import stat
import subprocess
import sys
from pathlib import Path

import can
import pytest
from click.testing import CliRunner

from blinkcan.cli.main import cli
from blinkcan.formats.log_source import MAX_LINE
from tests.formats.test_log_sources import CANDUMP, _fifo, _no_newline


def test_decode_reads_standard_input_as_a_candump_stream() -> None:
    result = CliRunner().invoke(cli, ["decode", "--json", "-"], input=CANDUMP)
    assert result.exit_code == 0, result.output
    assert len(result.stdout.splitlines()) == 2


def test_decode_and_convert_read_a_fifo(tmp_path: Path) -> None:
    with _fifo(tmp_path / "bus.log", CANDUMP.encode()) as path:
        result = CliRunner().invoke(cli, ["decode", "--json", str(path)])
    assert result.exit_code == 0, result.output
    assert len(result.stdout.splitlines()) == 2
    with _fifo(tmp_path / "again.log", CANDUMP.encode()) as path:
        result = CliRunner().invoke(cli, ["convert", str(path), str(tmp_path / "out.log")])
    assert result.exit_code == 0, result.output
    assert [m.arbitration_id for m in can.LogReader(str(tmp_path / "out.log"))] == [
        0x715, 0x18FF2115]


def _decode(path: Path) -> tuple[int, str, int]:
    """``blinkcan decode PATH`` in a child: exit code, stderr and peak memory (KiB)."""
    child = subprocess.Popen([sys.executable, "-m", "blinkcan", "decode", str(path)],
                             stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    assert child.stderr is not None
    error = child.stderr.read()
    _, status, usage = os.wait4(child.pid, 0)
    child.returncode = os.waitstatus_to_exitcode(status)
    child.stderr.close()
    return child.returncode, error, usage.ru_maxrss


def test_decode_of_a_file_without_newlines_is_one_line_in_bounded_memory(
        tmp_path: Path) -> None:
    small = tmp_path / "small.log"
    small.write_text(CANDUMP)
    huge = _no_newline(tmp_path / "huge.log", 64 << 20)
    code, _, baseline = _decode(small)
    assert code == 0
    code, error, peak = _decode(huge)
    assert code == 1
    assert error.splitlines()[-1] == (f"Error: {huge}: line 1 is over {MAX_LINE} bytes: "
                                      "not a candump log")
    assert peak - baseline < 16 << 10, f"{peak - baseline:,} KiB more to refuse a 64 MB line"


def test_decode_of_dev_zero_through_a_symlink_is_one_line(tmp_path: Path) -> None:
    if not stat.S_ISCHR(os.stat("/dev/zero").st_mode):
        pytest.skip("no /dev/zero here")
    link = tmp_path / "zero.log"
    link.symlink_to("/dev/zero")
    result = CliRunner().invoke(cli, ["decode", str(link)])
    assert result.exit_code == 1
    assert result.output.splitlines()[-1] == (
        f"Error: {link}: line 1 is over {MAX_LINE} bytes: not a candump log")
