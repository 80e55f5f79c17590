"""Files the command line writes: checked before any work starts (so a recording is not lost
at its end), never replaced without ``--force``, and any failure is one line naming the file."""

from __future__ import annotations

import os
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import click


def check_target(path: str, force: bool) -> Path:
    """``path`` if it can be written: its directory exists and is writable, and it does not
    exist yet (not even as a link to nowhere) unless ``force``."""
    target = Path(path)
    directory = target.parent
    if not directory.is_dir():
        raise click.ClickException(f"cannot write {path}: directory {directory} does not exist")
    if not os.access(directory, os.W_OK):
        raise click.ClickException(f"cannot write {path}: directory {directory} is read-only")
    if target.is_dir():
        raise click.ClickException(f"cannot write {path}: it is a directory")
    if (target.exists() or target.is_symlink()) and not force:  # a dangling link is the user's
        raise click.ClickException(f"{path} exists; pass --force to replace it")
    return target


@contextmanager
def writing(path: str, kept: str | None = None) -> Iterator[None]:
    """Turn a failure to write ``path`` into one line naming it (not the temporary file), and
    saying what of it is ``kept`` (a recording keeps what it flushed), or that nothing was
    recorded when the file could not even be made (it is not there to hold anything)."""
    try:
        yield
    except OSError as error:
        if kept is not None and not os.path.lexists(path):
            kept = "nothing was recorded"
        detail = "" if kept is None else f"; {kept}"
        raise click.ClickException(f"cannot write {path}: {error.strerror or error}{detail}"
                                   ) from None
