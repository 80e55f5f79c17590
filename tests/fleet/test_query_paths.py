"""blinkcan query on datasets where they really live: under a folder named like a Hive
partition (``site=north/lake``), under a name with glob characters (``fleet[2026]``), run from a
folder with DuckDB's default spill folder (``.tmp``) in it; and what it prints whatever the
values or the SQL (found by the attack pass)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from click.testing import CliRunner

from blinkcan.cli.main import cli
from blinkcan.fleet import decode_files
from tests.fleet.logs import Traffic, fleet_traffic, write_log

GROUPS = "SELECT model, count(*) AS n FROM events GROUP BY model ORDER BY model"


@pytest.fixture(scope="module")
def traffic() -> Traffic:
    return fleet_traffic()


def query(dataset: Path, sql: str, *options: str) -> tuple[int, str]:
    result = CliRunner().invoke(cli, ["query", str(dataset), sql, *options])
    return result.exit_code, result.output


@pytest.mark.parametrize("parent", ["model=north", "site=north", "date=2020-01-01"])
def test_a_dataset_under_a_folder_named_like_a_partition(tmp_path: Path, traffic: Traffic,
                                                         parent: str) -> None:
    log = write_log(tmp_path / "unit.log", traffic)
    decode_files([log], str(tmp_path / "plain"))
    decode_files([log], str(tmp_path / parent / "lake"))
    plain = query(tmp_path / "plain", GROUPS, "--csv")
    assert plain[0] == 0, plain[1]
    assert query(tmp_path / parent / "lake", GROUPS, "--csv") == plain
    columns = "SELECT column_name FROM (DESCRIBE events)"
    assert query(tmp_path / parent / "lake", columns, "--csv") == \
        query(tmp_path / "plain", columns, "--csv")


@pytest.mark.parametrize("name", ["fleet[1]", "fleet*", "fleet?"])
def test_a_dataset_whose_name_has_glob_characters(tmp_path: Path, traffic: Traffic,
                                                  name: str) -> None:
    log = write_log(tmp_path / "unit.log", traffic)
    decode_files([log], str(tmp_path / "fleet1"))
    decode_files([write_log(tmp_path / "other.log", traffic[:50])], str(tmp_path / name))
    status, output = query(tmp_path / name, "SELECT count(*) FROM events")
    assert (status, output) == (1, f"Error: {tmp_path / name}: DuckDB reads [, * and ? in a path "
                                "as a pattern; query a dataset whose path has none (rename it or "
                                "link to it)\n")
    linked = tmp_path / "linked"
    linked.symlink_to(tmp_path / name)
    status, output = query(linked, "SELECT count(DISTINCT source) AS files, min(source) AS source "
                           "FROM events", "--csv")
    assert (status, output) == (0, f"files,source\n1,{tmp_path / 'other.log'}\n")


def test_query_reads_nothing_of_the_folder_it_runs_in(tmp_path: Path, traffic: Traffic,
                                                      monkeypatch: pytest.MonkeyPatch) -> None:
    decode_files([write_log(tmp_path / "unit.log", traffic)], str(tmp_path / "lake"))
    (tmp_path / ".tmp").mkdir()
    (tmp_path / ".tmp" / "secret.txt").write_text("hunter2")
    monkeypatch.chdir(tmp_path)
    status, output = query(Path("lake"), f"SELECT * FROM read_text('{tmp_path}/.tmp/secret.txt')")
    assert status == 1
    assert output.startswith("Error: query reads only the dataset lake: ")
    assert "hunter2" not in output


@pytest.mark.parametrize("value", ["[/tmp/x]", "[bold red]loud[/bold red]", "[link=x]y"])
def test_a_value_is_printed_as_it_is(tmp_path: Path, traffic: Traffic, value: str) -> None:
    decode_files([write_log(tmp_path / "unit.log", traffic)], str(tmp_path / "lake"))
    status, output = query(tmp_path / "lake", f"SELECT '{value}' AS v, '{value}' AS \"{value}\"")
    assert status == 0, output
    assert output.count(value) == 3  # its name and two cells


@pytest.mark.parametrize("sql", ["", "   ", "/* nothing */", ";"])
def test_a_query_with_no_statement(tmp_path: Path, traffic: Traffic, sql: str) -> None:
    decode_files([write_log(tmp_path / "unit.log", traffic)], str(tmp_path / "lake"))
    status, output = query(tmp_path / "lake", sql)
    assert status == 2
    assert output.startswith("Error: no SQL statement: write a SELECT on the table events")
    assert len(output.splitlines()) == 1


def _strict(text: str) -> object:
    def refuse(constant: str) -> object:
        raise AssertionError(f"{constant} is not JSON")

    return json.loads(text, parse_constant=refuse)


def test_json_output_is_json_whatever_the_values(tmp_path: Path, traffic: Traffic) -> None:
    # NaN and infinities were written bare (not JSON: jq refuses them), and a blob or a date
    # inside a list or struct was "unexpected TypeError: Object of type bytes is not JSON
    # serializable"
    decode_files([write_log(tmp_path / "unit.log", traffic[:20])], str(tmp_path / "lake"))
    sql = ("SELECT 'nan'::double AS nan, 'inf'::double AS inf, '-inf'::double AS ninf, "
           "[data] AS blobs, {'at': time, 'raw': data} AS row, [date] AS dates, "
           "map([data], [1]) AS keyed FROM events LIMIT 1")
    status, output = query(tmp_path / "lake", sql, "--json")
    assert status == 0, output
    [line] = output.splitlines()
    row = _strict(line)
    assert isinstance(row, dict)
    assert (row["nan"], row["inf"], row["ninf"]) == ("NaN", "Infinity", "-Infinity")
    [blob] = row["blobs"]
    assert blob == row["row"]["raw"]
    assert list(row["keyed"]) == [blob]
    assert bytes.fromhex(blob)
    assert row["dates"][0] == row["row"]["at"][:10]


def test_json_output_keeps_every_column_of_a_repeated_name(tmp_path: Path,
                                                           traffic: Traffic) -> None:
    # SELECT 1 AS a, 2 AS a printed {"a": 2}: the first column was dropped
    decode_files([write_log(tmp_path / "unit.log", traffic[:20])], str(tmp_path / "lake"))
    status, output = query(tmp_path / "lake", "SELECT 1 AS a, 2 AS a, 3 AS a_1", "--json")
    assert status == 0, output
    assert json.loads(output) == {"a": 1, "a_1": 2, "a_1_1": 3}
