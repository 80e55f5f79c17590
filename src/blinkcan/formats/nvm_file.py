"""A twin's non-volatile memory in a JSON file, so its stored settings survive the process.

The file store behind ``KeypadTwin(nvm=PATH)`` and ``blinkcan emulate --nvm FILE``: it lives
here, beside the other files blinkcan writes from the device descriptions, because the twin
layer is pure (no file I/O); a twin takes any :class:`~blinkcan.twin.nvm.Nvm`, and a path
given to it is opened through :func:`nvm_file`. The rules for the file, so that nothing a
user stored is lost or replaced:

- The file is the one a path names after every symbolic link is followed (its *target*): a
  symlink is written through, never replaced by a regular file, and a symlink and its target
  are one file to the lock below.
- Written atomically: a temporary file beside the target, fsync, rename onto the target, fsync
  of its directory; the target keeps its permissions. The temporary file has one fixed name
  (``.NAME.tmp``), so one killed with ``kill -9`` mid-write is reclaimed by the next write, and
  removed when the file is next opened.
- One twin at a time: the opener holds an exclusive lock (``fcntl.flock`` on ``.NAME.lock``
  beside the target) until :meth:`JsonFileNvm.close`, and a second opener, in this process or
  another, through any symlink, is refused with an error naming the file and the holder's
  process id. The kernel drops the lock when its holder dies, so a crash never leaves the file
  locked. (No locking where ``fcntl`` does not exist, i.e. on Windows.)
- A file with more than one name (a hard link) is refused, at opening and at every write: the
  atomic rename gives the target a new inode, so the other names would silently keep the old
  settings, and a lock keyed by a name would let a second twin in through the other name.
  Writing in place instead would give up the atomicity (a write killed midway would leave half
  a file). One name and the resolved path is then one inode; a symlink is the way to give the
  file a second name.
- A file that is corrupt (nested too deeply or over MAX_SIZE included: never read whole),
  belongs to another model, or was changed by someone else since this twin read or wrote
  it, is refused with a clear error, never replaced.
- Every error is an :class:`NvmError` naming the file.

It needs no clock and no bus.
"""

from __future__ import annotations

import contextlib
import glob
import json
import os
import re
import stat
import sys
from collections.abc import Callable, Mapping
from pathlib import Path

from blinkcan.devices.objects import ObjectTable, Ranges, Value
from blinkcan.errors import NvmError

if sys.platform != "win32":
    import fcntl

FORMAT = "blinkcan-nvm"
VERSION = 1
#: bytes: an NVM file holds a device's settings (a few kB); a larger one is refused unread
MAX_SIZE = 1 << 20
_MKSTEMP_SUFFIX = re.compile(r"[a-z0-9_]{8}")


def _read_holder(lock: int) -> str:
    """The process id the holder wrote into the lock file, or "unknown"."""
    try:
        return os.pread(lock, 32, 0).decode("ascii", "replace").strip() or "unknown"
    except OSError:
        return "unknown"


class JsonFileNvm:
    """Settings in a JSON file tagged with the model and generation that wrote it; see the
    module docstring for the rules. Opening takes the file's lock (NvmError if taken).
    ``others``: stored settings that are not objects of ``table`` (the keypad's J1939 ones)."""

    def __init__(self, path: str | os.PathLike[str], model: str, generation: str,
                 table: ObjectTable, others: Mapping[str, Ranges] | None = None) -> None:
        self.path = Path(path)
        #: the file itself: every symbolic link followed (a symlink is written through)
        self.target = Path(os.path.realpath(self.path))
        #: the file as messages name it: the path given, and its target if that differs
        self.name = f"{self.path} (a link to {self.target})" if self.path.is_symlink() \
            else str(self.path)
        if self.target.is_dir() or not self.path.name:
            raise NvmError(f"NVM file {self.name} is a directory; name a file in it")
        if not self.target.parent.is_dir():  # a typo is not silently made a new directory
            raise NvmError(f"cannot open NVM file {self.name}: directory {self.target.parent} "
                           "does not exist")
        self.model = model
        self.generation = generation
        self._table = table
        self._others = dict(others or {})
        self._temporary = self.target.with_name(f".{self.target.name}.tmp")
        self._known: str | None = None  # the text this twin last read or wrote
        self._lock: int | None = self._acquire()
        try:
            self._check_one_name()
        except NvmError:
            self.close()
            raise
        self._remove_stale_temporaries()

    def _check_one_name(self) -> None:
        """Refuse a file with hard links (see the module docstring)."""
        try:
            names = self.target.stat().st_nlink
        except FileNotFoundError:
            return
        except OSError as error:
            raise NvmError(f"cannot open NVM file {self.name}: {error.strerror}") from error
        if names > 1:
            raise NvmError(
                f"NVM file {self.name} has {names} names (hard links); refusing it: its "
                "settings are replaced by an atomic rename, which would leave the other names "
                "with the old ones. Give it one name (a symbolic link may point at it)")

    def _remove_stale_temporaries(self) -> None:
        """Temporary files of writers killed mid-write: ours (``.NAME.tmp``) and those of
        earlier blinkcan versions (``.NAME.`` + eight ``tempfile.mkstemp`` characters)."""
        target = self.target
        stale = [self._temporary, *(
            path for path in target.parent.glob(f".{glob.escape(target.name)}.????????")
            if _MKSTEMP_SUFFIX.fullmatch(path.name[len(target.name) + 2:]))]
        for path in stale:
            with contextlib.suppress(OSError):
                path.unlink(missing_ok=True)

    # -- the lock ---------------------------------------------------------------------------

    def _acquire(self) -> int:
        """The lock's file descriptor, locked, with this process's id in it for the message
        of the next opener."""
        lock_path = self.target.with_name(f".{self.target.name}.lock")
        try:
            lock = os.open(lock_path, os.O_RDWR | os.O_CREAT | getattr(os, "O_CLOEXEC", 0),
                           0o644)
        except OSError as error:
            raise NvmError(f"cannot open NVM file {self.name}: cannot create its lock file "
                           f"{lock_path}: {error.strerror}") from error
        if sys.platform == "win32":
            return lock
        try:
            fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = _read_holder(lock)
            os.close(lock)
            raise NvmError(f"NVM file {self.name} is in use by another twin (process "
                           f"{holder}); close that one first or use another file") from None
        except OSError as error:  # a file system without locks: refused, not risked
            os.close(lock)
            raise NvmError(f"cannot lock NVM file {self.name}: {error.strerror}") from error
        try:  # a full disk or a file-size limit shows here first
            os.ftruncate(lock, 0)
            os.write(lock, f"{os.getpid()}\n".encode())
        except OSError as error:
            os.close(lock)  # and the lock with it
            raise NvmError(f"cannot use NVM file {self.name}: writing its lock file "
                           f"{lock_path} failed: {error.strerror}") from error
        return lock

    def close(self) -> None:
        """Release the lock; the file can then be opened by another twin or process."""
        if self._lock is not None:
            os.close(self._lock)  # closing the descriptor drops the flock
            self._lock = None

    def _check_open(self) -> None:
        if self._lock is None:
            raise NvmError(f"NVM file {self.name} was closed by this twin")

    # -- reading ----------------------------------------------------------------------------

    def load(self) -> dict[str, Value] | None:
        self._check_open()
        text = self._read()
        if text is None:
            self._known = None
            return None
        settings = self._parse(text)
        self._known = text
        return settings

    def _read(self) -> str | None:
        try:
            with self.target.open("rb") as stream:
                data = stream.read(MAX_SIZE + 1)
            if len(data) > MAX_SIZE:  # never read whole: a hostile or mistaken file
                raise NvmError(f"NVM file {self.name} is over {MAX_SIZE >> 20} MiB, far more "
                               "than any device's settings; refusing it")
            return data.decode("utf-8")
        except FileNotFoundError:
            return None
        except (OSError, UnicodeDecodeError) as error:
            reason = error.strerror if isinstance(error, OSError) else "not UTF-8 text"
            raise NvmError(f"cannot read NVM file {self.name}: {reason}") from error

    def _parse(self, text: str) -> dict[str, Value]:
        try:
            document = json.loads(text)
        except json.JSONDecodeError as error:
            raise NvmError(f"NVM file {self.name} is not valid JSON ({error.msg}, line "
                           f"{error.lineno}); refusing to replace it") from error
        except RecursionError as error:  # a hostile file: arrays in arrays, 100,000 deep
            raise NvmError(f"NVM file {self.name} is nested too deeply to be an NVM file; "
                           "refusing to replace it") from error
        if not isinstance(document, dict) or document.get("format") != FORMAT:
            raise NvmError(f"{self.name} is not a blinkcan NVM file; refusing to replace it")
        if document.get("version") != VERSION:
            raise NvmError(f"{self.name} has NVM format version {document.get('version')!r}, "
                           f"this blinkcan reads version {VERSION}")
        model, generation = document.get("model"), document.get("generation")
        if (model, generation) != (self.model, self.generation):
            raise NvmError(f"{self.name} holds the settings of a {model} (generation "
                           f"{generation}), not of a {self.model} (generation "
                           f"{self.generation}); use another file")
        settings = document.get("settings")
        if not isinstance(settings, dict):
            raise NvmError(f"{self.name} has no settings object")
        return self._checked(settings)

    def _checked(self, settings: dict[str, object]) -> dict[str, Value]:
        checked: dict[str, Value] = {}
        for name, value in settings.items():
            if name in self._others:
                if not isinstance(value, int) or value not in self._others[name]:
                    raise NvmError(f"{self.name}: {name} = {value!r} is not valid "
                                   f"({self._others[name]})")
                checked[name] = value
                continue
            if name not in self._table or not self._table[name].stored:
                raise NvmError(f"{self.name}: {name!r} is not a stored setting of a {self.model}")
            entry = self._table[name]
            if not isinstance(value, (int, str)) or not entry.accepts(value):
                raise NvmError(f"{self.name}: {name} = {value!r} is not valid "
                               f"({entry.describe_valid()})")
            checked[name] = value
        return checked

    # -- writing ----------------------------------------------------------------------------

    def save(self, settings: dict[str, Value]) -> None:
        self._check_open()
        if self._read() != self._known:
            raise NvmError(f"NVM file {self.name} was changed by someone else since this twin "
                           "read it; refusing to replace it (a reset of the twin loads it)")
        self._check_one_name()  # linked since it was opened: a rename would split the names
        document = {
            "format": FORMAT,
            "version": VERSION,
            "model": self.model,
            "generation": self.generation,
            "settings": dict(sorted(settings.items())),
        }
        text = json.dumps(document, indent=2) + "\n"
        try:
            self._write_atomically(text)
        except OSError as error:
            with contextlib.suppress(OSError):
                self._temporary.unlink(missing_ok=True)
            raise NvmError(f"cannot write NVM file {self.name}: {error.strerror}") from error
        self._known = text

    def _write_atomically(self, text: str) -> None:
        """``text`` in the target, or the target as it was (see the module docstring)."""
        try:
            mode: int | None = stat.S_IMODE(self.target.stat().st_mode)
        except FileNotFoundError:
            mode = None
        with open(self._temporary, "w", encoding="utf-8") as stream:
            if mode is not None:
                os.fchmod(stream.fileno(), mode)
            stream.write(text)
            stream.flush()
            os.fsync(stream.fileno())
        os.replace(self._temporary, self.target)
        if sys.platform != "win32":  # the rename itself on disk too
            directory = os.open(self.target.parent, os.O_RDONLY)
            try:
                os.fsync(directory)
            finally:
                os.close(directory)


def nvm_file(path: str | os.PathLike[str]) -> Callable[
        [str, str, ObjectTable, Mapping[str, Ranges] | None], JsonFileNvm]:
    """The file store for ``path``, opened (and locked) when a twin is built on it with its
    model's identity: ``KeypadTwin(nvm=nvm_file(path))``; a twin given the path itself does
    the same."""
    def open_file(model: str, generation: str, table: ObjectTable,
                  others: Mapping[str, Ranges] | None = None) -> JsonFileNvm:
        return JsonFileNvm(path, model, generation, table, others)
    return open_file
