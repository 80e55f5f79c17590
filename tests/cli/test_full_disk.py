"""A full disk (simulated by a file size limit, as ``ulimit -f``) while converting: one line
naming the file, exit 1, no half-written file left, whatever the target format (found by the
attack pass: .db was "unexpected OperationalError: disk I/O error")."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from blinkcan.formats.log_writers import WRITERS

#: the CLI under a file size limit of 64 KiB
LIMITED = ("import resource, sys; resource.setrlimit(resource.RLIMIT_FSIZE, (65536, 65536)); "
           "from blinkcan.cli.main import main; sys.argv[0] = 'blinkcan'; main()")
FORMATS = sorted({".pcap", *WRITERS} - {".mf4"})  # .mf4: asammdf, where it is installed


def limited(*arguments: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-c", LIMITED, *arguments], capture_output=True,
                          text=True, timeout=120, check=False)


@pytest.mark.parametrize("suffix", FORMATS)
def test_convert_onto_a_full_disk(tmp_path: Path, suffix: str) -> None:
    source = tmp_path / "big.log"
    source.write_text("".join(f"({n / 1000:.6f}) can0 195#0800000001\n" for n in range(20000)))
    target = tmp_path / f"out{suffix}"
    result = limited("convert", str(source), str(target))
    assert result.returncode == 1, result
    assert len(result.stderr.splitlines()) == 1, result.stderr
    assert result.stderr.startswith(f"Error: cannot write {target}: "), result.stderr
    assert not target.exists()
