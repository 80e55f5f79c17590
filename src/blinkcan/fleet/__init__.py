"""Fleet logs: many CAN log files decoded into one Parquet dataset (a row per event, Hive
partitions by model and date), on this machine or a Dask cluster; queried with DuckDB.

Needs the optional extra: ``pip install 'blinkcan[fleet]'`` (pyarrow, numpy, DuckDB, Dask,
zstandard). ``decode_files`` is imported on first use, so ``import blinkcan.fleet`` works
without it and :func:`missing` names what is not installed.
"""

from __future__ import annotations

from importlib import import_module
from importlib.util import find_spec
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from blinkcan.fleet.run import decode_files
    from blinkcan.fleet.task import FileResult

__all__ = ["EXTRA", "FileResult", "decode_files", "missing"]

#: what a user types to get what this package needs
EXTRA = "pip install 'blinkcan[fleet]'"
_LAZY = {"decode_files": "blinkcan.fleet.run", "FileResult": "blinkcan.fleet.task"}


def missing(*modules: str) -> list[str]:
    """Which of the modules (default: those of decoding) are not installed."""
    wanted = modules or ("pyarrow", "numpy", "fsspec", "zstandard")
    return [name for name in wanted if find_spec(name) is None]


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'blinkcan.fleet' has no attribute {name!r}")
    return getattr(import_module(module), name)
