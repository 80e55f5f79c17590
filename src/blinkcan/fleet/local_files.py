"""The dataset's folder on this machine's disk, without fsspec: the six calls the fleet's task
and writer make (``makedirs``, ``open``, ``exists``, ``rm``, ``ls``, ``mv``), as fsspec's
``LocalFileSystem`` makes them. Importing fsspec costs a decoding process about 0.1 s of CPU
(it loads asyncio), a third of a second per million frames of start-up (issue 23); a URL
(``s3://``, ``memory://``, ``file://``, a ``::`` chain) still goes through fsspec.
"""

from __future__ import annotations

import os
import shutil
from typing import IO, Any


def is_local(out: str) -> bool:
    """``out`` is a plain path (no URL scheme, no fsspec chain)."""
    return "://" not in out and "::" not in out


def local_root(out: str) -> str:
    """The absolute path fsspec's ``url_to_fs`` makes of a plain path (``~`` expanded)."""
    return os.path.abspath(os.path.expanduser(out)).replace(os.sep, "/")


class LocalFiles:
    """fsspec's local filesystem calls the fleet uses, on ``os`` and ``shutil``."""

    protocol = "file"

    @staticmethod
    def makedirs(path: str, exist_ok: bool = False) -> None:
        os.makedirs(path, exist_ok=exist_ok)

    @staticmethod
    def open(path: str, mode: str = "rb") -> IO[Any]:
        return open(path, mode)

    @staticmethod
    def exists(path: str) -> bool:
        return os.path.lexists(path)

    @staticmethod
    def rm(path: str, recursive: bool = False) -> None:
        if os.path.isdir(path) and not os.path.islink(path):
            if not recursive:
                raise IsADirectoryError(path)
            shutil.rmtree(path)
        else:
            os.remove(path)

    @staticmethod
    def ls(path: str, detail: bool = False) -> list[str]:
        if detail:
            raise ValueError("LocalFiles.ls lists names only (detail=False)")
        return [f"{path.rstrip('/')}/{name}" for name in sorted(os.listdir(path))]

    @staticmethod
    def mv(source: str, target: str) -> None:
        """A rename that replaces ``target`` (one filesystem: the dataset's folder)."""
        os.replace(source, target)
