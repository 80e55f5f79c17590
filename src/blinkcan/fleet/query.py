"""The dataset as the table ``events`` in an embedded DuckDB connection, confined to it.

The connection reads the dataset's folder and nothing else: DuckDB's ``allowed_directories``
names the dataset, ``enable_external_access = false`` refuses every other file, URL and
extension download, and ``lock_configuration`` keeps a query from lifting either. SQL comes from
users and scripts; a query about the fleet must not read ``/etc/passwd`` or fetch a URL. DuckDB
resolves links before it checks a path, so a link inside the dataset pointing out of it is
refused too. Its spill folder (which DuckDB allows to be read) is a private, empty temporary
folder of the connection's own, not ``.tmp`` in the working directory.

The partition columns ``model`` and ``date`` are read from the last two folders of each file's
path, not by DuckDB's Hive parsing, which takes every ``key=value`` folder of the whole path: a
dataset kept under ``site=north/lake`` or ``model=x/lake`` would gain a column or have every
row's model replaced."""

from __future__ import annotations

import shutil
import tempfile
import weakref

import duckdb
from fsspec.core import url_to_fs

#: the data files of a dataset (the _blinkcan/ folder beside them is not data)
DATA_FILES = "model=*/date=*/*.parquet"

#: the partition columns, from a data file's path (DuckDB regexp_extract patterns)
PARTITIONS = {"date": r"/date=([^/]*)/[^/]*$", "model": r"/model=([^/]*)/date=[^/]*/[^/]*$"}


#: characters DuckDB reads as a pattern in a path (its permission check reads them as written)
GLOB_CHARACTERS = "[*?"


def _sql_literal(text: str) -> str:
    return "'" + text.replace("'", "''") + "'"


def connect(dataset: str) -> duckdb.DuckDBPyConnection:
    """A DuckDB connection with the view ``events`` over the dataset at ``dataset`` (a folder
    or an fsspec URL; DuckDB reads the files through fsspec)."""
    fs, root = url_to_fs(dataset)
    root = root.rstrip("/")
    if any(character in root for character in GLOB_CHARACTERS):
        # DuckDB would read the name as a pattern (fleet[1] is fleet1) and escaping it fails its
        # permission check (the escaped pattern is not under the allowed folder as written)
        raise ValueError(f"{dataset}: DuckDB reads [, * and ? in a path as a pattern; query a "
                         "dataset whose path has none (rename it or link to it)")
    if not fs.glob(f"{root}/{DATA_FILES}"):
        raise ValueError(f"{dataset}: no decoded events there (blinkcan decode LOG "
                         f"--parquet {dataset} writes them)")
    spill = tempfile.mkdtemp(prefix="blinkcan-query-")
    connection = duckdb.connect(config={"temp_directory": spill})
    weakref.finalize(connection, shutil.rmtree, spill, ignore_errors=True)
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
    connection.execute(
        "CREATE VIEW events AS SELECT * EXCLUDE (filename), "
        f"CAST(regexp_extract(filename, {_sql_literal(PARTITIONS['date'])}, 1) AS DATE) AS date, "
        f"regexp_extract(filename, {_sql_literal(PARTITIONS['model'])}, 1) AS model "
        f"FROM read_parquet({_sql_literal(location)}, hive_partitioning = false, "
        "union_by_name = true, filename = true)")
    return connection
