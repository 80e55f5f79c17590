"""The dataset's columns as its readers see them are the README's (issue 23): DuckDB's types,
pyarrow's (every file's schema, its documentation included, and the dataset's), whatever the
writer does to write them faster (a column encoded as a dictionary still reads as strings)."""

from __future__ import annotations

from pathlib import Path

import pyarrow as pa
import pyarrow.dataset as ds
import pyarrow.parquet as pq
import pytest

from blinkcan.fleet import decode_files
from blinkcan.fleet.query import connect
from blinkcan.fleet.schema import SCHEMA
from tests.fleet.logs import fleet_traffic, write_log

#: the README's table of columns as DuckDB types them (`DESCRIBE events`)
DUCKDB_TYPES = {
    "time": "TIMESTAMP WITH TIME ZONE", "source": "VARCHAR", "channel": "VARCHAR",
    "can_id": "INTEGER", "extended": "BOOLEAN", "node": "SMALLINT", "kind": "VARCHAR",
    "key": "SMALLINT", "pin": "SMALLINT", "state": "VARCHAR", "colour": "VARCHAR",
    "value": "BIGINT", "text": "VARCHAR", "data": "BLOB", "date": "DATE", "model": "VARCHAR",
}


@pytest.fixture(scope="module")
def lake(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("schema")
    log = write_log(root / "unit.log", fleet_traffic())
    [result] = decode_files([log], str(root / "lake"))
    assert result.status == "decoded"
    return root / "lake"


def test_duckdb_reads_the_documented_types(lake: Path) -> None:
    with connect(str(lake)) as connection:
        described = connection.execute(
            "SELECT column_name, column_type FROM (DESCRIBE events)").fetchall()
        models = {m for (m,) in connection.execute("SELECT DISTINCT model FROM events")
                  .fetchall()}
    assert dict(described) == DUCKDB_TYPES
    assert len(models) > 1  # files of several partitions, read as one table


def test_every_file_has_the_schema_with_its_documentation(lake: Path) -> None:
    files = sorted(lake.glob("model=*/date=*/*.parquet"))
    assert len(files) > 1
    for path in files:
        schema = pq.read_schema(path)
        assert schema.equals(SCHEMA, check_metadata=True), path
        assert not any(pa.types.is_dictionary(field.type) for field in schema), path


def test_pyarrow_dataset_reads_strings_not_dictionaries(lake: Path) -> None:
    table = ds.dataset(lake, format="parquet", partitioning="hive").to_table()
    assert table.schema.names == [*SCHEMA.names, "model", "date"]
    for field in SCHEMA:
        assert table.schema.field(field.name).type == field.type, field.name
    assert table.schema.field("model").type == pa.string()
    assert table.num_rows == sum(pq.ParquetFile(p).metadata.num_rows
                                 for p in lake.glob("model=*/date=*/*.parquet"))
