"""Many log files into one dataset: in this process, on ``jobs`` local processes, or one task
per file on a Dask cluster. Every way runs the same per-file task (``task.py``), so the
dataset is the same whichever ran it."""

from __future__ import annotations

import json
import os
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path
from typing import TYPE_CHECKING, Any

from blinkcan.decode.nodes import ModelsByNode, split_devices
from blinkcan.fleet.schema import ROWS_PER_GROUP
from blinkcan.fleet.task import (
    FILES,
    META,
    FileResult,
    dataset_files,
    decode_file,
    file_entry,
    source_key,
)

if TYPE_CHECKING:
    from concurrent.futures import Future

#: seconds between a worker's checks that the process that started it still runs
PARENT_CHECK = 0.5


@dataclass(frozen=True)
class Sources:
    """The files a run decodes: ``files`` each real file once, in order; ``same`` every other
    name of one of them (a hard link, a symbolic link, a name given twice) -> the name it is
    decoded under."""

    files: list[str]
    same: dict[str, str]
    #: every name, each once, in order
    names: list[str]
    #: a file decoded before under a name that no longer exists (renamed since) -> that name:
    #: its task skips it if unchanged, else replaces the old name's rows (``task.py``)
    renamed: dict[str, str] = field(default_factory=dict)


def find_sources(paths: Iterable[str | os.PathLike[str]], out: str | None = None) -> Sources:
    """The files to decode, each once, in order: a folder stands for the files under it, in
    name order (hidden ones and ``_`` names, such as a dataset's own, left out, and the dataset
    ``out`` itself when it is among them: ``decode logs --parquet logs/lake`` run again must not
    read the dataset as logs). Links are followed: a linked folder is read (once, however many
    links lead to it; a link to a folder being read is a loop, not read again), and a file
    reached by several names is decoded under one (``Sources.same`` names the others): the
    one the dataset ``out`` has it decoded under already, else the first.
    A file the dataset has under a name not given (a hard link made since it was decoded) is
    found by its identity (st_dev, st_ino, ``task.file_entry``): it is decoded (or skipped)
    under that name, which joins ``names`` before its first name given, and the names given
    are "same" as it. Found so under a name that no longer exists (the file was renamed
    since), it is decoded (or skipped) under its name given, the old name in ``renamed``.
    A name that is no readable file (a dangling link, a pipe) is kept: its task names it."""
    dataset = None if out is None or "://" in out else os.path.abspath(out)
    real_dataset = None if dataset is None else os.path.realpath(dataset)
    names: list[str] = []
    walked: set[tuple[int, int]] = set()
    for path in paths:
        source = os.path.abspath(os.fspath(path))
        if os.path.isdir(source):
            names.extend(_walk(source, (dataset, real_dataset), walked))
        else:
            names.append(source)
    known: dict[object, list[str]] = {}
    for name in dict.fromkeys(names):
        try:
            found = os.stat(name)
            identity: object = (found.st_dev, found.st_ino)
        except OSError:  # a dangling link, a loop: its task says why it cannot be read
            identity = name
        known.setdefault(identity, []).append(name)
    files: list[str] = []
    same: dict[str, str] = {}
    before: dict[str, str] = {}  # a name given -> the name not given its file is taken under
    renamed: dict[str, str] = {}
    decoded = None if out is None else _Decoded(out)
    for identity, each in known.items():
        chosen = each[0] if decoded is None else decoded.decoded_under(each, identity)
        if chosen not in each and not os.path.lexists(chosen):  # renamed since: the file is
            renamed[each[0]] = chosen  # its new name's, the old name's rows replaced by it
            chosen = each[0]
        files.append(chosen)
        same.update((name, chosen) for name in each if name != chosen)
        if chosen not in each:
            before[each[0]] = chosen
    ordered = [name for given in dict.fromkeys(names)
               for name in ((before[given], given) if given in before else (given,))]
    return Sources(files, same, ordered, renamed)


class _Decoded:
    """What the dataset at ``out`` has decoded: the names of its manifests and of its index
    of files (``task.FILES``), each folder listed once (a URL's too: no request per file)."""

    def __init__(self, out: str) -> None:
        self.fs, self.root = dataset_files(out)
        self.manifests = self._listed(f"{self.root}/{META}")
        self.entries = self._listed(f"{self.root}/{FILES}")

    def _listed(self, folder: str) -> set[str]:
        try:
            return {path.rstrip("/").rsplit("/", 1)[-1]
                    for path in self.fs.ls(folder, detail=False)}
        except OSError:  # none yet
            return set()

    def decoded_under(self, names: list[str], identity: object) -> str:
        """Of the names of one file, the one the dataset has a manifest for (an earlier run
        decoded the file under it: its names may have come in another order); else the name
        the index of files gives for its ``identity`` (st_dev, st_ino) if that name still
        names this file and has a manifest (a hard link given alone, the other name decoded
        before), or no longer exists (the file renamed since: the caller decodes it under its
        new name, ``Sources.renamed``); else the first. A manifest is keyed by the name
        (``task.source_key``), so decoding under another name would put every frame of the
        file in the dataset a second time."""
        for name in names:
            if f"{source_key(name)}.json" in self.manifests:
                return name
        if not isinstance(identity, tuple) or file_entry(*identity) not in self.entries:
            return names[0]
        try:
            with self.fs.open(f"{self.root}/{FILES}/{file_entry(*identity)}", "rb") as stream:
                hint = json.loads(stream.read()).get("source")
            if not isinstance(hint, str) or f"{source_key(hint)}.json" not in self.manifests:
                return names[0]
            if not os.path.lexists(hint):
                return hint  # renamed since (the task checks the manifest's file identity)
            found = os.stat(hint)
        except (OSError, ValueError, AttributeError):  # gone, corrupt: no hint
            return names[0]
        return hint if (found.st_dev, found.st_ino) == identity else names[0]


def _walk(folder: str, dataset: tuple[str | None, str | None],
          walked: set[tuple[int, int]]) -> list[str]:
    """The names under ``folder`` in name order, depth first (so the order of sorted paths);
    each real folder read once; the dataset left out by its name and by where links lead."""
    if _in_dataset(folder, dataset):
        return []
    real = os.path.realpath(folder)
    found = os.stat(folder)
    if (found.st_dev, found.st_ino) in walked:
        return []
    walked.add((found.st_dev, found.st_ino))
    names: list[str] = []
    for name in sorted(os.listdir(folder)):
        if name.startswith((".", "_")):
            continue
        inner = os.path.join(folder, name)
        if _in_dataset(inner, dataset):
            continue
        if not os.path.isdir(inner):
            names.append(inner)
        elif not Path(real).is_relative_to(os.path.realpath(inner)):  # a link back: a loop
            names.extend(_walk(inner, dataset, walked))
    return names


def _in_dataset(name: str, dataset: tuple[str | None, str | None]) -> bool:
    """``name`` is in the dataset, or leads there (a link: the dataset may not exist yet)."""
    return any(d is not None and Path(f).is_relative_to(d)
               for f, d in ((name, dataset[0]), (os.path.realpath(name), dataset[1])))


def log_files(paths: Iterable[str | os.PathLike[str]], out: str | None = None) -> list[str]:
    """The files to decode, each real file once, in order (:func:`find_sources`)."""
    return find_sources(paths, out).files


def decode_files(paths: Iterable[str | os.PathLike[str]], out: str, client: Any = None,
                 jobs: int | None = None, *, force: bool = False,
                 devices: ModelsByNode | None = None,
                 rows_per_group: int = ROWS_PER_GROUP,
                 on_result: Callable[[FileResult], None] | None = None,
                 on_frames: Callable[[int], None] | None = None) -> list[FileResult]:
    """Decode log files (or folders of them) into the Parquet dataset at ``out``: a folder or
    any fsspec URL (``s3://bucket/lake``, ``memory://lake``). With ``client`` (a
    ``dask.distributed.Client``) one task per file runs on its workers (they must see the
    files and ``out``); else ``jobs`` local processes (default 1: this process). Returns one
    result per name, in order; a file that cannot be read is a "failed" result, the others
    go on; another name of a file already listed (a link) is a "same" result. ``on_result``
    hears each result as it comes, ``on_frames`` frame counts (in this process only).
    ``devices`` maps node ids to models (``{0x15: "keypad@1.5"}``) and J1939 addresses too
    (``{"j1939:0x30": "keypad"}``); ValueError for one that names no device."""
    if jobs is not None and jobs < 1:
        raise ValueError(f"jobs must be 1 or more, not {jobs}")
    split_devices(devices)  # checked here, not once per file on the workers
    found = find_sources(paths, out)
    sources = found.files
    same = {name: FileResult(name, "same", same_as=first) for name, first in found.same.items()}
    if on_result is not None:
        for result in same.values():
            on_result(result)
    task = partial(decode_file, out=out, force=force, devices=dict(devices or {}),
                   rows_per_group=rows_per_group, renamed=found.renamed)
    if client is not None:
        results = _on_dask(client, sources, task, on_result)
    elif jobs is None or jobs == 1 or len(sources) < 2:
        results = {}
        for source in sources:
            results[source] = result = task(source, progress=on_frames)
            if on_result is not None:
                on_result(result)
    else:
        results = _on_processes(min(jobs, len(sources)), sources, task, on_result)
    results.update(same)
    return [results[name] for name in found.names]


def _on_processes(jobs: int, sources: list[str], task: Callable[..., FileResult],
                  on_result: Callable[[FileResult], None] | None) -> dict[str, FileResult]:
    """The files on ``jobs`` local processes. A worker that dies (the OOM killer, a kill -9)
    breaks python's pool and fails every file not yet done, those never started too: they
    are run again on a new pool, as Dask runs a dead worker's task again; after a second
    break each is run alone, so only a file that kills its worker every time fails (its
    output is written aside and renamed, so a re-run never leaves half of it)."""
    results: dict[str, FileResult] = {}

    def finished(source: str, result: FileResult) -> None:
        results[source] = result
        if on_result is not None:
            on_result(result)

    pending = list(sources)
    for _attempt in range(2):
        pending = _pool_run(min(jobs, len(pending)), pending, task, finished,
                            keep_broken=True)
        if not pending:
            return results
    for source in pending:  # alone: a break now is this file's own
        _pool_run(1, [source], task, finished, keep_broken=False)
    return results


def _pool_run(jobs: int, sources: list[str], task: Callable[..., FileResult],
              finished: Callable[[str, FileResult], None], keep_broken: bool) -> list[str]:
    """Run ``sources`` on a pool of ``jobs`` processes, handing each result to ``finished``
    as it comes; with ``keep_broken``, the files whose pool broke are returned instead."""
    import multiprocessing  # noqa: PLC0415 (-j only: start-up)
    from concurrent.futures import ProcessPoolExecutor, as_completed  # noqa: PLC0415
    from concurrent.futures.process import BrokenProcessPool  # noqa: PLC0415

    methods = multiprocessing.get_all_start_methods()
    # fork: the workers need nothing of __main__ (python -m blinkcan runs the CLI on import)
    context = multiprocessing.get_context("fork" if "fork" in methods else None)
    broken: list[str] = []
    others = set(multiprocessing.active_children())
    pool = ProcessPoolExecutor(jobs, mp_context=context, initializer=_start_worker,
                               initargs=(os.getpid(),))
    futures: dict[Future[FileResult], str] = {}
    try:
        for source in sources:
            futures[pool.submit(task, source)] = source
        for future in as_completed(futures):
            source = futures[future]
            if keep_broken and isinstance(future.exception(), BrokenProcessPool):
                broken.append(source)
            else:
                finished(source, _result(source, future))
    except BaseException:
        # Ctrl-C (or an error of on_result), also while the files are handed out: no file
        # starts any more, and the files in flight stop now, not when they end; their rows
        # were written aside and never appear (the next run removes them and decodes those
        # files again). The workers are the children that appeared since the pool was made.
        # The pool's manager thread cancels the queued files itself (the shutdown reaches it
        # before any worker's death): a future cancelled here, then failed by that thread
        # as the workers die, raised InvalidStateError in it (a traceback on Ctrl-C). The
        # workers are joined here: the shutdown below no longer waits for that thread.
        pool.shutdown(wait=False, cancel_futures=True)
        workers = [w for w in multiprocessing.active_children() if w not in others]
        for worker in workers:
            worker.terminate()
        for worker in workers:
            worker.join()
        raise
    finally:
        pool.shutdown(wait=True, cancel_futures=True)
    return [source for source in sources if source in broken]  # in their order


def _start_worker(parent: int) -> None:
    """In each worker: Ctrl-C is the parent's to handle (a terminal sends it to every
    process of the group; the parent stops the workers), and a worker whose parent died
    (kill -9, the OOM killer) ends instead of waiting for work forever."""
    import signal  # noqa: PLC0415
    import threading  # noqa: PLC0415

    signal.signal(signal.SIGINT, signal.SIG_IGN)

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(PARENT_CHECK)
        os._exit(1)

    threading.Thread(target=watch, name="blinkcan-parent-watch", daemon=True).start()


def _on_dask(client: Any, sources: list[str], task: Callable[..., FileResult],
             on_result: Callable[[FileResult], None] | None) -> dict[str, FileResult]:
    from distributed import as_completed as dask_completed  # noqa: PLC0415 (optional)

    # pure=False: a task is run again when asked again (the file may have grown); a worker
    # that dies has its task run again elsewhere (the scheduler's allowed-failures)
    futures = {client.submit(task, source, pure=False, key=f"blinkcan-decode-{n}-"
                             f"{os.urandom(6).hex()}"): source
               for n, source in enumerate(sources)}
    results: dict[str, FileResult] = {}
    for future in dask_completed(list(futures)):  # type: ignore[no-untyped-call]
        source = futures[future]
        results[source] = result = _result(source, future)
        if on_result is not None:
            on_result(result)
    return results


def _result(source: str, future: Any) -> FileResult:
    """The task's result, or a failed one naming what stopped it (a killed worker, ...)."""
    try:
        result = future.result()
    except Exception as error:
        return FileResult(source, "failed", error=f"{type(error).__name__}: {error}")
    assert isinstance(result, FileResult)
    return result
