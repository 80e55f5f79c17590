"""A recording whose file cannot even be created (here: SQLite's first page over a file-size
limit, as on a disk that is already full) said "what was recorded up to its last flush is in
it" of a file that was not there (hatk10's attack pass): the message now says nothing was
recorded, and names no file as holding anything."""

from __future__ import annotations

import os
import resource
import subprocess
import sys
import uuid
from pathlib import Path

import pytest

import blinkcan

SRC = Path(blinkcan.__file__).resolve().parent.parent


def _limit_file_size() -> None:
    resource.setrlimit(resource.RLIMIT_FSIZE, (2048, resource.RLIM_INFINITY))


@pytest.mark.skipif(not hasattr(resource, "RLIMIT_FSIZE"), reason="no file-size limit here")
def test_a_recording_that_left_no_file_says_so(tmp_path: Path) -> None:
    target = tmp_path / "capture.db"
    result = subprocess.run(
        [sys.executable, "-m", "blinkcan", "record", str(target), "--duration", "0.2",
         "-i", "virtual", "-c", f"no-file-{uuid.uuid4().hex}"],
        check=False, capture_output=True, text=True, timeout=120, preexec_fn=_limit_file_size,
        env={**os.environ, "PYTHONPATH": f"{SRC}{os.pathsep}{os.environ.get('PYTHONPATH', '')}"})
    assert result.returncode == 1, result.stderr
    assert not target.exists()
    assert f"Error: cannot write {target}:" in result.stderr
    assert "is in it" not in result.stderr
    assert "nothing was recorded" in result.stderr
