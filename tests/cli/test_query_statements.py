"""``blinkcan query LAKE "SELECT ...; SELECT ..."``: DuckDB runs every statement and returns the
last one's rows, so the first query's answer vanished without a word (``SELECT 1; SELECT 2``
printed 2 only). One statement at a time, refused in one line otherwise."""

from __future__ import annotations

from pathlib import Path

import pytest
from click.testing import CliRunner

from blinkcan.cli.main import cli

pytest.importorskip("duckdb", reason="the fleet extra is not installed")


@pytest.fixture
def lake(tmp_path: Path) -> Path:
    log = tmp_path / "unit.log"
    log.write_text("(1.0) can0 715#05\n(2.0) can0 195#0400000001\n")
    out = tmp_path / "lake"
    result = CliRunner().invoke(cli, ["decode", str(log), "--parquet", str(out)])
    assert result.exit_code == 0, result.output
    return out


def test_two_statements_are_refused(lake: Path) -> None:
    result = CliRunner().invoke(cli, ["query", str(lake), "SELECT 1 AS a; SELECT 2 AS b",
                                      "--csv"])
    assert result.exit_code == 2
    assert "one statement at a time: this SQL has 2" in result.output
    assert "b\n2" not in result.output


@pytest.mark.parametrize("sql", ["SELECT count(*) AS n FROM events",
                                 "SELECT count(*) AS n FROM events;"])
def test_one_statement_with_or_without_its_semicolon_runs(lake: Path, sql: str) -> None:
    result = CliRunner().invoke(cli, ["query", str(lake), sql, "--csv"])
    assert result.exit_code == 0, result.output
    assert result.stdout == "n\n2\n"
