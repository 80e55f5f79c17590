"""The dataset as the table ``events`` in an embedded DuckDB connection."""

from __future__ import annotations

import duckdb
from fsspec.core import url_to_fs

#: the data files of a dataset (the _blinkcan/ folder beside them is not data)
DATA_FILES = "model=*/date=*/*.parquet"


def connect(dataset: str) -> duckdb.DuckDBPyConnection:
    """A DuckDB connection with the view ``events`` over the dataset at ``dataset`` (a folder
    or an fsspec URL; DuckDB reads the files through fsspec)."""
    fs, root = url_to_fs(dataset)
    root = root.rstrip("/")
    connection = duckdb.connect()
    if not fs.glob(f"{root}/{DATA_FILES}"):
        connection.close()
        raise ValueError(f"{dataset}: no decoded events there (blinkcan decode LOG "
                         f"--parquet {dataset} writes them)")
    protocol = fs.protocol if isinstance(fs.protocol, str) else fs.protocol[0]
    if protocol in ("file", "local"):
        location = f"{root}/{DATA_FILES}"
    else:
        connection.register_filesystem(fs)
        location = f"{protocol}://{root.lstrip('/')}/{DATA_FILES}"
    literal = location.replace("'", "''")
    connection.execute(f"CREATE VIEW events AS SELECT * FROM read_parquet('{literal}', "
                       "hive_partitioning = true, union_by_name = true)")
    return connection
