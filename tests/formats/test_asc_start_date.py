"""An ``.asc`` log whose first frame falls in the first 100 ms of a second read back with
every absolute time shifted (found by the attack pass): python-can writes the start date's
milliseconds unpadded (``20.50`` for 20.050 s), which reads back as 20.500 s."""

from __future__ import annotations

from pathlib import Path

import pytest
from click.testing import CliRunner

from blinkcan.cli.main import cli
from blinkcan.formats.logs import read_messages


@pytest.mark.parametrize("fraction", ["000000", "005000", "050000", "099999", "100000",
                                      "999000"])
def test_absolute_times_read_back_as_written_whatever_the_first_millisecond(
        tmp_path: Path, fraction: str) -> None:
    first = f"1796180000.{fraction}"
    times = [float(first), float(first) + 0.01, float(first) + 1.5]
    source = tmp_path / "trace.log"
    source.write_text("".join(f"({t:.6f}) can0 715#05 R\n" for t in times))
    target = tmp_path / "trace.asc"
    result = CliRunner().invoke(cli, ["convert", str(source), str(target)])
    assert result.exit_code == 0, result.output
    assert "lost" not in result.output
    back = [m.timestamp for m in read_messages(target)]
    assert back == pytest.approx(times, abs=1.5e-6), target.read_text()
