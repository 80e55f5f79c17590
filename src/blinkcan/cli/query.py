"""``blinkcan query OUT "SELECT ... FROM events ..."``: SQL on the fleet dataset with DuckDB
(embedded, no server), printed as a table, CSV or JSON lines. Needs the [fleet] extra."""

from __future__ import annotations

import csv
import datetime
import json
import math
import sys
from typing import Any

import click
from rich.console import Console
from rich.table import Table
from rich.text import Text

from blinkcan import fleet
from blinkcan.cli.extras import install_command

#: rows printed as a table at most (CSV and JSON print all)
TABLE_ROWS = 1000


def _json_value(value: Any) -> Any:
    """A value DuckDB returned as JSON: bytes as hex, times in ISO 8601, intervals in seconds,
    NaN and the infinities as the strings "NaN", "Infinity", "-Infinity" (JSON has no such
    numbers; protobuf's JSON mapping writes them so), inside lists, structs and maps too."""
    if isinstance(value, float) and not math.isfinite(value):
        return "NaN" if math.isnan(value) else ("Infinity" if value > 0 else "-Infinity")
    if isinstance(value, (bytes, bytearray, memoryview)):
        return bytes(value).hex()
    if isinstance(value, (datetime.datetime, datetime.date, datetime.time)):
        return value.isoformat()
    if isinstance(value, datetime.timedelta):
        return value.total_seconds()
    if isinstance(value, dict):
        return {_json_key(key): _json_value(item) for key, item in value.items()}
    if isinstance(value, (list, tuple)):
        return [_json_value(item) for item in value]
    return value if isinstance(value, (int, float, str, bool, type(None))) else str(value)


def _json_key(key: Any) -> str:
    """A map's key as a JSON object's (a string)."""
    converted = _json_value(key)
    return converted if isinstance(converted, str) else json.dumps(converted)


def _unique(names: list[str]) -> list[str]:
    """The column names with repeats numbered as DuckDB numbers them in a table (a, a_1)."""
    seen: set[str] = set()
    unique = []
    for name in names:
        candidate, number = name, 0
        while candidate in seen:
            number += 1
            candidate = f"{name}_{number}"
        seen.add(candidate)
        unique.append(candidate)
    return unique


def _check_reads_only(connection: Any, sql: str) -> None:
    """Raise unless every statement of ``sql`` is a SELECT (DESCRIBE, SHOW, SUMMARIZE, WITH,
    VALUES are SELECTs to DuckDB): a query never writes, copies, attaches or deletes a file."""
    import duckdb  # noqa: PLC0415 (the [fleet] extra, checked by the caller)

    statements = connection.extract_statements(sql)
    if not statements:
        raise click.UsageError("no SQL statement: write a SELECT on the table events")
    for statement in statements:
        if statement.type != duckdb.StatementType.SELECT:
            raise click.ClickException(
                f"query only reads: {statement.query.strip()!r} is not a SELECT (DESCRIBE, "
                "SHOW, SUMMARIZE, WITH and VALUES are)")
    if len(statements) > 1:  # DuckDB returns the last one's rows: the others would vanish
        raise click.UsageError(f"one statement at a time: this SQL has {len(statements)} "
                               "(run each as its own query, or join them with UNION ALL)")


@click.command("query")
@click.argument("dataset", metavar="OUT", type=click.Path())
@click.argument("sql")
@click.option("--csv", "as_csv", is_flag=True, help="CSV with a header line.")
@click.option("--json", "as_json", is_flag=True, help="One JSON object per row.")
def command(dataset: str, sql: str, as_csv: bool, as_json: bool) -> None:
    """Run SQL on the dataset `blinkcan decode --parquet OUT` wrote: its rows are the table
    `events` (columns: time, source, channel, can_id, extended, node, kind, key, pin, state,
    colour, value, text, data, model, date). It only reads, and only the dataset: every statement
    must be a SELECT, and no other file or URL can be read."""
    if as_csv and as_json:
        raise click.UsageError("--csv and --json are two outputs: choose one")
    absent = fleet.missing("duckdb", "fsspec")
    if absent:
        raise click.ClickException(f"query needs {', '.join(absent)}: "
                                   f"{install_command('fleet')}")
    import duckdb  # noqa: PLC0415 (the [fleet] extra, checked above)

    from blinkcan.fleet.query import connect  # noqa: PLC0415

    try:
        with connect(dataset) as connection:
            _check_reads_only(connection, sql)
            result = connection.execute(sql)
            names = [column[0] for column in result.description or []]
            rows = result.fetchall()
    except duckdb.PermissionException as error:
        raise click.ClickException(f"query reads only the dataset {dataset}: "
                                   f"{str(error).splitlines()[0]}") from None
    except (duckdb.Error, ValueError) as error:
        raise click.ClickException(str(error).splitlines()[0]) from None
    out = sys.stdout
    if as_csv:
        writer = csv.writer(out, lineterminator="\n")
        writer.writerow(names)
        writer.writerows([[_json_value(v) for v in row] for row in rows])
    elif as_json:
        names = _unique(names)  # a JSON object holds a name once: a second 'a' is 'a_1'
        for row in rows:
            out.write(json.dumps(dict(zip(names, map(_json_value, row), strict=True)),
                                 allow_nan=False) + "\n")
    else:
        table = Table(show_lines=False)
        for name in names:  # names and values are shown as they are, never read as markup
            table.add_column(Text(name))
        for row in rows[:TABLE_ROWS]:
            table.add_row(*(Text("" if v is None else str(_json_value(v))) for v in row))
        Console().print(table)
        if len(rows) > TABLE_ROWS:
            click.echo(f"{len(rows):,} rows; the first {TABLE_ROWS:,} shown (--csv or --json "
                       "print all)", err=True)
