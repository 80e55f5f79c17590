"""The dataset as the table ``events`` in an embedded DuckDB connection, confined to it.

The connection reads the dataset's folder and nothing else: DuckDB's ``allowed_directories``
names the dataset, ``enable_external_access = false`` refuses every other file, URL and
extension download, and ``lock_configuration`` keeps a query from lifting either. SQL comes from
users and scripts; a query about the fleet must not read ``/etc/passwd`` or fetch a URL. (Links
inside the dataset's folder are followed: DuckDB checks the path as written.)"""

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
        allowed = [f"{root}/"]
    else:
        connection.register_filesystem(fs)
        location = f"{protocol}://{root.lstrip('/')}/{DATA_FILES}"
        # DuckDB names an fsspec file with one slash or three after the scheme, as it globs
        allowed = [f"{protocol}://{root.lstrip('/')}/", f"{protocol}:///{root.lstrip('/')}/"]
    connection.execute("SET allowed_directories = ?", [allowed])
    connection.execute("SET enable_external_access = false")
    connection.execute("SET lock_configuration = true")
    literal = location.replace("'", "''")
    connection.execute(f"CREATE VIEW events AS SELECT * FROM read_parquet('{literal}', "
                       "hive_partitioning = true, union_by_name = true)")
    return connection
