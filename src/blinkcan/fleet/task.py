"""One log file into the dataset: the task that runs in a process, a pool or on a Dask worker.

Whole or nothing, and never twice:
- the rows are written to ``_blinkcan/tmp/<key>-<attempt>/`` (readers skip ``_`` names);
- only once the whole log is decoded, a journal ``_blinkcan/<key>.pending.json`` names every
  file about to be replaced, the files are renamed into their partitions, the file's older
  outputs that the new decoding does not have are removed, and the manifest
  ``_blinkcan/<key>.json`` (source, size, mtime, blinkcan version, outputs) is written and the
  journal removed;
- a task that finds a journal (its predecessor died while renaming) removes what the journal
  names first, and the attempts of dead predecessors (their temporary folders);
- a file whose manifest matches its size, mtime, blinkcan version and decoding settings is
  skipped unless ``force``, and only while every output its manifest names is there: a
  partition file deleted from the dataset is decoded again (``FileResult.missing`` names
  it), its rows never silently lost;
- the manifest keeps the file's identity (``file``: st_dev, st_ino) and the index of files
  ``_blinkcan/files/<st_dev>-<st_ino>.json`` names the source it was decoded under, so that
  a later run given another name of it (a hard link made since) finds it (``run.py``). The
  index is a hint, checked against the file system; manifests without ``file`` (an older
  blinkcan's) are read as before;
- a file decoded before under a name that no longer exists (renamed since: ``run.py`` finds
  it by the index) is that file only where the old manifest's ``file`` is its (st_dev,
  st_ino): unchanged, it is skipped (``FileResult.same_as`` names the old name), else decoded
  under its new name, the old name's outputs and manifest replaced (the journal names them),
  so that its rows are never in the dataset twice.

One task at a time per source: on this machine's disk a lock file per source
(``_blinkcan/locks/<key>.lock``) keeps two runs at once on one dataset apart (the second
finds the file decoded), so every attempt folder of the source a task finds is a dead one's.

``<key>`` is a hash of the source's absolute path, so one source always writes the same names.
A file that cannot be read is a failed result with the reason, never an exception; a line
that is no frame is an ``unreadable`` row, counted and named in the result (and the manifest).
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import logging
import os
import uuid
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from blinkcan import __version__
from blinkcan.decode.decoder import Decoder
from blinkcan.decode.nodes import ModelsByNode
from blinkcan.devices.registry import describe_device
from blinkcan.fleet.frames import FrameDecoder, Segment
from blinkcan.fleet.local_files import LocalFiles, is_local, local_root
from blinkcan.fleet.schema import ROWS_PER_GROUP
from blinkcan.fleet.sources import read_columns
from blinkcan.fleet.writer import PartitionWriter
from blinkcan.formats.logs import LogError
from blinkcan.formats.unreadable import UnreadableCount, UnreadableLine

try:
    import fcntl
except ImportError:  # not POSIX: runs at once on one dataset are not kept apart
    fcntl = None  # type: ignore[assignment]

if TYPE_CHECKING:  # fsspec loads for a URL only (start-up: fleet/local_files.py)
    from fsspec import AbstractFileSystem

log = logging.getLogger(__name__)

META = "_blinkcan"
#: how often (in frames) a local task reports its progress
PROGRESS_EVERY = 16_384
#: the devices assumed where none are given: each model's own default node id
DEFAULT_DEVICES = ("keypad", "keybox")


@dataclass(frozen=True)
class FileResult:
    """What became of one source file: ``status`` is "decoded", "skipped" (already decoded
    by this blinkcan version), "failed" (``error`` says why) or "same" (another name of a
    file the run decodes: a hard or symbolic link; ``same_as`` names it)."""

    source: str
    status: str
    frames: int = 0
    rows: int = 0
    outputs: tuple[str, ...] = ()
    error: str | None = None
    #: a decoded file's last line that was cut off (a logger killed mid-write): every frame
    #: before it is in the dataset, the line is named here
    cut_off: str | None = None
    #: the lines of a decoded file that are no frame (each an ``unreadable`` row with its
    #: text), and the first few of them named
    unreadable: int = 0
    unreadable_lines: tuple[str, ...] = ()
    #: outputs of an earlier decoding that were gone from the dataset (deleted since): the
    #: file was decoded again for them
    missing: tuple[str, ...] = ()
    #: for "same": the name the file is decoded under; for "skipped": the name the file was
    #: decoded under before it was renamed (that name no longer exists), if not its own
    same_as: str | None = None


def source_key(source: str) -> str:
    return hashlib.sha256(source.encode()).hexdigest()[:20]


#: the index of files, in the dataset: an entry per file (st_dev, st_ino) decoded
FILES = f"{META}/files"


def file_entry(device: int, inode: int) -> str:
    """The name of the index entry of the file (st_dev, st_ino), in :data:`FILES`: it names
    the source the file was last decoded under."""
    return f"{device}-{inode}.json"


def dataset_files(out: str) -> tuple[AbstractFileSystem | LocalFiles, str]:
    """The filesystem of the dataset ``out`` (a plain path: the disk, directly) and its root
    there, with no "/" at the end."""
    if is_local(out):
        return LocalFiles(), local_root(out).rstrip("/")
    from fsspec.core import url_to_fs  # noqa: PLC0415 (a URL only)

    filesystem, root = url_to_fs(out)
    return filesystem, root.rstrip("/")


def make_decoder(devices: ModelsByNode | None) -> Decoder:
    """The decoder of ``devices`` (node ids and "j1939:ADDR" to models), else the defaults."""
    if devices:
        return Decoder(devices)
    known = [describe_device(name) for name in DEFAULT_DEVICES]
    return Decoder({d.default_node_id: d for d in known}, assumed=True)


class _Store:
    """The dataset's folder on any fsspec filesystem (a plain path: on the disk, directly)."""

    def __init__(self, out: str, key: str) -> None:
        self.fs, self.root = dataset_files(out)
        self.meta = f"{self.root}/{META}"
        self.manifest = f"{self.meta}/{key}.json"
        self.journal = f"{self.meta}/{key}.pending.json"
        self.temporary = f"{self.meta}/tmp"
        self.key = key
        #: the documents found corrupt, said once each
        self.corrupt: set[str] = set()

    def read_json(self, path: str) -> dict[str, Any] | None:
        """The document at ``path``; None where there is none, or where it is corrupt (not
        JSON, not an object, nested past Python's recursion limit): that is said once, and
        the file is decoded again as if never decoded."""
        try:
            with self.fs.open(path, "rb") as stream:
                document = json.loads(stream.read())
        except FileNotFoundError:
            return None
        except (ValueError, RecursionError) as error:
            document = error
        if isinstance(document, dict):
            return document
        if path not in self.corrupt:
            self.corrupt.add(path)
            reason = f"{type(document).__name__}" if isinstance(document, Exception) else \
                f"a JSON {type(document).__name__}, not an object"
            log.warning("%s is corrupt (%s): read as if absent", path, reason)
        return None

    def write_json(self, path: str, document: dict[str, object]) -> None:
        """Written aside, then renamed: never half a manifest."""
        aside = f"{self.temporary}/{self.key}-{uuid.uuid4().hex}.json"
        self.fs.makedirs(self.temporary, exist_ok=True)
        with self.fs.open(aside, "wb") as stream:
            stream.write(json.dumps(document, indent=1).encode())
        self.fs.mv(aside, path)

    def remove(self, path: str) -> None:
        if self.fs.exists(path):
            self.fs.rm(path, recursive=True)

    @contextlib.contextmanager
    def alone(self) -> Iterator[None]:
        """Held while a task handles its source: a task of another run at once (two runs on
        one dataset) waits, then finds the file decoded; without it, it took the first's
        attempt for a dead predecessor's and removed it under it. A lock file per source
        (``_blinkcan/locks/<key>.lock``, ``flock``) on a dataset on this machine's disk; on
        an object store two runs at once are not kept apart."""
        if fcntl is None or "file" not in _protocols(self.fs):
            yield
            return
        folder = f"{self.meta}/locks"
        os.makedirs(folder, exist_ok=True)
        with open(f"{folder}/{self.key}.lock", "ab") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX)  # released when the file is closed
            yield

    def recover(self) -> None:
        """Undo what a dead predecessor left: a journal's files, its temporary folders."""
        journal = self.read_json(self.journal)
        if journal is not None or self.fs.exists(self.journal):  # corrupt: outputs unknown,
            self.remove(self.manifest)  # the file is decoded again over its own
            for relative in (journal or {}).get("outputs", []):
                self.remove(f"{self.root}/{relative}")
            self.remove(self.journal)
        if self.fs.exists(self.temporary):
            for path in self.fs.ls(self.temporary, detail=False):
                if path.rstrip("/").rsplit("/", 1)[-1].startswith(f"{self.key}-"):
                    self.remove(path)

    def commit(self, attempt: str, outputs: list[str], manifest: dict[str, object],
               entry: str, replaced: Renamed | None = None) -> None:
        """The outputs into their partitions, the index ``entry`` of the file, then the
        manifest (the entry is a hint, taken only where the manifest it leads to is there).
        ``replaced``: the file's decoding under its old name (renamed since), removed."""
        old = self.read_json(self.manifest) or {}
        gone = [] if replaced is None else replaced.outputs
        stale = [p for p in (*old.get("outputs", []), *gone) if p not in outputs]
        self.write_json(self.journal, {"outputs": sorted({*outputs, *stale})})
        self.remove(self.manifest)
        if replaced is not None:
            self.remove(replaced.manifest_path)
        for relative in outputs:
            target = f"{self.root}/{relative}"
            self.fs.makedirs(target.rsplit("/", 1)[0], exist_ok=True)
            self.fs.mv(f"{attempt}/{relative}", target)
        for relative in stale:
            self.remove(f"{self.root}/{relative}")
        self.fs.makedirs(f"{self.root}/{FILES}", exist_ok=True)
        self.write_json(f"{self.root}/{FILES}/{entry}", {"source": manifest["source"]})
        self.write_json(self.manifest, manifest)
        self.remove(self.journal)
        self.remove(attempt)


@dataclass(frozen=True)
class Renamed:
    """A file's decoding under the name it had before it was renamed."""

    name: str
    manifest_path: str
    manifest: dict[str, Any]

    @property
    def outputs(self) -> list[str]:
        return [str(o) for o in self.manifest.get("outputs", [])]


def _renamed_from(store: _Store, path: str, stat: os.stat_result,
                  renamed: Mapping[str, str] | None) -> Renamed | None:
    """The decoding of this file under its old name, where ``run.find_sources`` found one
    (``renamed``: new name -> old name) and its manifest is this very file's (st_dev, st_ino);
    a manifest without ``file`` (an older blinkcan's) or another file's: None."""
    name = (renamed or {}).get(path)
    if name is None or os.path.lexists(name):
        return None
    manifest_path = f"{store.meta}/{source_key(name)}.json"
    manifest = store.read_json(manifest_path)
    if manifest is None or manifest.get("file") != [stat.st_dev, stat.st_ino]:
        return None
    return Renamed(name, manifest_path, manifest)


def decode_file(source: str | os.PathLike[str], out: str, *, force: bool = False,
                devices: ModelsByNode | None = None,
                rows_per_group: int = ROWS_PER_GROUP,
                progress: Callable[[int], None] | None = None,
                renamed: Mapping[str, str] | None = None) -> FileResult:
    """Decode one log file into the dataset at ``out`` (a folder or an fsspec URL).
    ``progress`` (local runs) hears the count of frames decoded every PROGRESS_EVERY.
    ``renamed`` (``run.Sources.renamed``): a new name -> the name the file was decoded under
    before it was renamed; that decoding is the file's (skipped if unchanged, else
    replaced)."""
    path = os.path.abspath(os.fspath(source))
    try:
        stat = os.stat(path)
    except OSError as error:
        return FileResult(path, "failed", error=f"cannot read: {error.strerror or error}")
    store = _Store(out, source_key(path))
    # node ids in order, then J1939 addresses ("j1939:0x30"): as before J1939 could be named
    settings = {"devices": sorted(([node, model] for node, model in (devices or {}).items()),
                                  key=lambda pair: (isinstance(pair[0], str), pair[0]))}
    identity = {"source": path, "size": stat.st_size, "mtime_ns": stat.st_mtime_ns,
                "blinkcan": __version__, "settings": settings}
    with store.alone():
        return _decode_alone(store, path, stat, identity, force, devices, rows_per_group,
                             progress, renamed)


def _decode_alone(store: _Store, path: str, stat: os.stat_result, identity: dict[str, Any],
                  force: bool, devices: ModelsByNode | None, rows_per_group: int,
                  progress: Callable[[int], None] | None,
                  renamed: Mapping[str, str] | None) -> FileResult:
    """:func:`decode_file` once no other task handles the source (:meth:`_Store.alone`)."""
    store.recover()
    old = store.read_json(store.manifest)
    before = _renamed_from(store, path, stat, renamed) if old is None else None
    if before is not None:  # judged as the old name's decoding, its name aside
        old = {**before.manifest, "source": path}
    decoded_before = not force and old is not None and \
        all(old.get(k) == v for k, v in identity.items())
    outputs = old.get("outputs", []) if old is not None else []
    missing = tuple(o for o in outputs if not store.fs.exists(f"{store.root}/{o}")) \
        if decoded_before else ()
    if old is not None and decoded_before and not missing:
        return FileResult(path, "skipped", int(old.get("frames", 0)), int(old.get("rows", 0)),
                          tuple(outputs), cut_off=old.get("cut_off"),
                          unreadable=int(old.get("unreadable", 0)),
                          unreadable_lines=tuple(old.get("unreadable_lines", ())),
                          same_as=None if before is None else before.name)
    attempt = f"{store.temporary}/{store.key}-{uuid.uuid4().hex}"
    writer = PartitionWriter(store.fs, attempt, f"{store.key}.parquet", path, rows_per_group)
    try:
        scratch = attempt if isinstance(store.fs, LocalFiles) else None
        frames, unreadable = _decode_into(writer, path, devices, progress, scratch)
        outputs = writer.close()
    except Exception as error:  # a file that cannot be read (or decoded): named and skipped
        writer.abandon()
        store.remove(attempt)
        return FileResult(path, "failed", error=_reason(error))
    except BaseException:
        writer.abandon()
        store.remove(attempt)
        raise
    cut_off = None if unreadable.cut_off is None else str(unreadable.cut_off)
    named = [str(line) for line in unreadable.named]
    manifest = {**identity, "file": [stat.st_dev, stat.st_ino], "outputs": outputs,
                "frames": frames, "rows": writer.rows, "unreadable": unreadable.count,
                "unreadable_lines": named, "cut_off": cut_off}
    store.commit(attempt, outputs, manifest, file_entry(stat.st_dev, stat.st_ino), before)
    return FileResult(path, "decoded", frames, writer.rows, tuple(outputs), cut_off=cut_off,
                      unreadable=unreadable.count, unreadable_lines=tuple(named),
                      missing=missing)


def _decode_into(writer: PartitionWriter, path: str, devices: ModelsByNode | None,
                 progress: Callable[[int], None] | None, scratch: str | None
                 ) -> tuple[int, UnreadableCount]:
    """The frames decoded, and the lines that are no frame (each an ``unreadable`` row; a
    capture whose logger was killed ends in one, cut off). A compressed log is decompressed
    in ``scratch`` (a local attempt folder) where it must be."""
    frames = FrameDecoder(make_decoder(devices))
    segment = Segment()
    limit = writer.rows_per_group
    count = reported = 0
    unreadable = UnreadableCount()
    for block in read_columns(path, scratch=scratch):
        position, size = 0, len(block)
        if block.others:
            for item in block.others.values():
                if isinstance(item, UnreadableLine):
                    unreadable.add(item)
                    size -= 1
        while position < len(block):
            position = frames.decode(block, position, segment, limit)
            if segment.rows >= limit:
                writer.write(segment)
                segment.clear()
        count += size
        if progress is not None and count - reported >= PROGRESS_EVERY:
            progress(count - reported)
            reported = count
    writer.write(segment)
    if progress is not None and count > reported:
        progress(count - reported)
    return count, unreadable


def _protocols(filesystem: AbstractFileSystem | LocalFiles) -> tuple[str, ...]:
    """fsspec's names of ``filesystem``'s protocol ("file" for this machine's disk)."""
    found = filesystem.protocol
    return (found,) if isinstance(found, str) else tuple(found)


def _reason(error: BaseException) -> str:
    if isinstance(error, LogError):
        return str(error)
    text = str(error).splitlines()[0] if str(error) else ""
    return f"{type(error).__name__}: {text}" if text else type(error).__name__
