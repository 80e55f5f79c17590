"""``record OUT --force`` replaces what is at OUT, as ``convert`` and ``export`` do with
``--force``: a FIFO (or a socket, a device node's name) left at OUT was refused with "OUT
exists; pass --force to replace it", --force given (hatk10's attack pass)."""

from __future__ import annotations

import os
import uuid
from pathlib import Path

import pytest
from click.testing import CliRunner

from blinkcan.cli.main import cli
from blinkcan.formats.logs import read_messages


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs here")
@pytest.mark.parametrize("suffix", [".log", ".pcap", ".db"])
def test_record_force_replaces_a_fifo(tmp_path: Path, suffix: str) -> None:
    target = tmp_path / f"capture{suffix}"
    os.mkfifo(target)
    channel = f"fifo-{uuid.uuid4().hex}"
    result = CliRunner().invoke(cli, ["record", str(target), "--force", "--duration", "0.1",
                                      "-i", "virtual", "-c", channel])
    assert result.exit_code == 0, result.output
    assert "pass --force" not in result.output
    assert target.is_file()
    assert list(read_messages(target)) == []


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs here")
def test_record_without_force_still_refuses_a_fifo(tmp_path: Path) -> None:
    target = tmp_path / "capture.log"
    os.mkfifo(target)
    result = CliRunner().invoke(cli, ["record", str(target), "--duration", "0.1",
                                      "-i", "virtual", "-c", f"fifo-{uuid.uuid4().hex}"])
    assert result.exit_code == 1
    assert "exists; pass --force to replace it" in result.output
    assert not target.is_file()
