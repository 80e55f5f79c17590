"""The file a capture is written to, as ``tcpdump -w`` writes one: under its own name from the
first frame, created exclusively (never through a symlink planted at its name, never over a file
that exists unless asked to), and handed to the disk in whole records only, so a recorder killed
at any moment leaves a file that is valid up to its last flush.
"""

from __future__ import annotations

import io
import os
from pathlib import Path

#: O_NOFOLLOW where the platform has it (not on Windows, which has no symlinks to plant)
_NOFOLLOW = getattr(os, "O_NOFOLLOW", 0)
_CLOEXEC = getattr(os, "O_CLOEXEC", 0)


def create_exclusively(path: Path, replace: bool) -> int:
    """A new, empty file at ``path``, opened for writing (its descriptor).

    ``O_EXCL`` refuses anything already there, a symlink included (it is never followed, even
    dangling); with ``replace`` what is there is removed first (a symlink itself, not what it
    points to; a FIFO or socket left at the name too, as a conversion's rename replaces it; a
    directory never). Raises FileExistsError when ``path`` exists and ``replace`` is not set."""
    if replace and (path.is_symlink() or (path.exists() and not path.is_dir())):
        path.unlink()
    return os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL | _NOFOLLOW | _CLOEXEC, 0o644)


class WholeRecords(io.RawIOBase):
    """A file descriptor that receives only what :meth:`flush` hands it: the writes since the
    last flush, in one go. A writer that flushes between records (frames, a BLF container)
    never leaves half a record in the file, however it is stopped.

    Seekable (BLF rewrites its header in place); ``name`` is what writers print in headers."""

    def __init__(self, fd: int, name: str) -> None:
        super().__init__()
        self._fd = fd
        self.name = name
        self._pending: list[bytes] = []
        self._pending_size = 0

    def writable(self) -> bool:
        return True

    def seekable(self) -> bool:
        return True

    def fileno(self) -> int:
        return self._fd

    def write(self, data: bytes | bytearray | memoryview) -> int:  # type: ignore[override]
        chunk = bytes(data)
        self._pending.append(chunk)
        self._pending_size += len(chunk)
        return len(chunk)

    def flush(self) -> None:
        """Hand the writes since the last flush to the file; when they cannot all be written
        (a full disk: the system may take part of them first), the file is cut back to where
        they began, so it still ends with a whole record."""
        if self.closed or not self._pending:
            return
        view = memoryview(b"".join(self._pending))
        self._pending.clear()
        self._pending_size = 0
        start = os.lseek(self._fd, 0, os.SEEK_CUR)
        try:
            while view:
                written = os.write(self._fd, view)
                view = view[written:]
        except OSError:
            os.ftruncate(self._fd, start)
            os.lseek(self._fd, start, os.SEEK_SET)
            raise

    def tell(self) -> int:
        return os.lseek(self._fd, 0, os.SEEK_CUR) + self._pending_size

    def seek(self, offset: int, whence: int = os.SEEK_SET) -> int:
        self.flush()
        return os.lseek(self._fd, offset, whence)

    def sync(self) -> None:
        """Flush, and have the system put it on the disk."""
        self.flush()
        os.fsync(self._fd)

    def close(self) -> None:
        if self.closed:
            return
        try:
            self.sync()
        finally:
            os.close(self._fd)
            super().close()
