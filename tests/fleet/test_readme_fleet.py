"""The README's "Fleet logs" section runs as written: its commands on a folder of two units'
logs, and the three questions print the answers it shows."""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import pytest
from click.testing import CliRunner

from blinkcan.cli.main import cli
from tests.fleet.logs import fleet_traffic, write_log

README = Path(__file__).resolve().parents[2] / "README.md"


def _section() -> str:
    return README.read_text().split("## Fleet logs", 1)[1].split("\n## ", 1)[0]


def _blocks(language: str) -> list[str]:
    return re.findall(rf"```{language}\n(.*?)```", _section(), re.DOTALL)


def test_the_fleet_section_runs_and_answers_as_shown(tmp_path: Path,
                                                     monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    traffic = fleet_traffic(taps=3)
    for unit in ("boat-07", "boat-12"):
        (tmp_path / "logs" / unit).mkdir(parents=True)
        write_log(tmp_path / "logs" / unit / "2026-05-31.log", traffic)
    printed = []
    for block in _blocks("sh"):
        for line in block.splitlines():
            if line.startswith("blinkcan "):
                result = CliRunner().invoke(cli, shlex.split(line)[1:], env={"COLUMNS": "200"})
                assert result.exit_code == 0, f"{line}\n{result.output}"
                if line.endswith("--csv"):
                    printed.append(result.stdout)
    [shown] = _blocks("text")
    assert "".join(printed) == shown
    for block in _blocks("python"):
        compile(block, "README.md", "exec")
