"""``blinkcan decode LOG... --parquet OUT [-j N] [--force]``: logs into the fleet dataset,
with a progress bar (files, frames, rate) on a terminal. Needs the [fleet] extra; imported
only then."""

from __future__ import annotations

import contextlib
import sys
import time
from collections.abc import Callable
from typing import TYPE_CHECKING

import click

from blinkcan import fleet
from blinkcan.cli.collector import collector_for_decoding
from blinkcan.cli.extras import install_command
from blinkcan.decode.nodes import NodeKey

if TYPE_CHECKING:
    from rich.progress import Progress

    from blinkcan.fleet.task import FileResult


def check_extra() -> None:
    """One line naming the install command when the [fleet] extra is missing."""
    absent = fleet.missing()
    if absent:
        raise click.ClickException(f"--parquet needs {', '.join(absent)}: "
                                   f"{install_command('fleet')}")


def _progress_bar(total: int) -> Progress:
    """rich's bar of files, frames and rate (loaded for a terminal only: a tenth of a second
    of start-up that a script or a pipe would pay for nothing)."""
    from rich.console import Console  # noqa: PLC0415
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn  # noqa: PLC0415

    progress = Progress(TextColumn("{task.completed:,.0f}/{task.total:,.0f} files"),
                        BarColumn(), TextColumn("{task.fields[frames]:,} frames"),
                        TextColumn("{task.fields[rate]:,.0f} frames/s"), TimeElapsedColumn(),
                        console=Console(stderr=True), transient=True,
                        auto_refresh=False)  # no thread: -j forks the workers
    progress.add_task("decode", total=total, frames=0, rate=0.0)
    return progress


def unreadable_text(result: FileResult) -> str:
    """"x.log: 3 lines could not be read (named above): kept as 'unreadable' rows with their
    text; its 2,998 frames are in the dataset"."""
    plural = "s" if result.unreadable != 1 else ""
    more = f", the first {len(result.unreadable_lines)}" \
        if result.unreadable > len(result.unreadable_lines) else ""
    return (f"{result.source}: {result.unreadable:,} line{plural} could not be read (named "
            f"above{more}): kept as 'unreadable' row{plural} with {'their' if plural else 'its'}"
            f" text; its {result.frames:,} frames are in the dataset")


def _links_text(names: int, files: int) -> str:
    """The summary's part for other names (links) of files listed: decoded once each."""
    if not names:
        return ""
    return (f", {names} other name{'' if names == 1 else 's'} of "
            f"{'a file' if files == 1 else 'files'} listed (links) not decoded twice")


def decode_to_parquet(files: tuple[str, ...], out: str, jobs: int, force: bool,
                      devices: dict[NodeKey, str]) -> None:
    check_extra()
    with collector_for_decoding():  # from the imports on: CPU per frame (cli/collector.py)
        _decode(files, out, jobs, force, devices)


def _other_name_text(result: FileResult, linked_to: set[str]) -> str:
    """The line of a result with ``same_as``: "same" (a link, counted in ``linked_to``), or
    "skipped" (the file decoded before under a name it no longer has: renamed)."""
    if result.status == "same":
        linked_to.add(str(result.same_as))
        return (f"{result.source}: the same file as {result.same_as} (a link): decoded once, "
                "under that name")
    return f"{result.source}: the file decoded before as {result.same_as} (renamed): not " \
        "decoded again"


def _decode(files: tuple[str, ...], out: str, jobs: int, force: bool,
            devices: dict[NodeKey, str]) -> None:
    from blinkcan.fleet.run import decode_files, find_sources  # noqa: PLC0415 (the extra)

    total = len(find_sources(files, out).names)
    start = time.monotonic()
    frames = 0
    counts = {"decoded": 0, "skipped": 0, "failed": 0, "same": 0}
    again = 0  # decoded again: files of theirs were gone from the dataset
    linked_to: set[str] = set()  # the files other names (links) of which were listed
    progress = _progress_bar(total) if sys.stderr.isatty() else None
    running: contextlib.AbstractContextManager[object] = progress if progress is not None else \
        contextlib.nullcontext()

    def say(line: str) -> None:
        if progress is None:
            click.echo(line, err=True)
        else:
            progress.console.print(line, markup=False, highlight=False, soft_wrap=True)

    def show(advance: int = 0) -> None:
        if progress is not None:
            rate = frames / max(time.monotonic() - start, 1e-9)
            progress.update(progress.task_ids[0], advance=advance, frames=frames, rate=rate,
                            refresh=True)

    def on_frames(count: int) -> None:  # one process: live counts
        nonlocal frames
        frames += count
        show()

    def on_result(result: FileResult) -> None:
        nonlocal frames, again
        counts[result.status] += 1
        if result.missing:  # nothing a user stored is lost silently: say it is back
            again += 1
            say(f"{result.source}: decoded again, {len(result.missing)} of its files were "
                f"gone from the dataset: {', '.join(result.missing)}")
        if result.status == "failed":
            say(f"cannot decode {result.source}: {result.error}")
        elif result.same_as is not None:  # a link, or a file renamed since it was decoded
            say(_other_name_text(result, linked_to))
        elif result.status == "decoded" and jobs > 1:  # frames seen when a file is done
            frames += result.frames
        if result.unreadable:
            for line in result.unreadable_lines:
                say(f"{result.source}: {line}")
            say(unreadable_text(result))
        show(advance=1)

    frames_heard: Callable[[int], None] | None = on_frames if jobs == 1 else None
    with running:
        decode_files(files, out, jobs=jobs, force=force, devices=devices,
                     on_result=on_result, on_frames=frames_heard)
    elapsed = time.monotonic() - start
    skipped = f", {counts['skipped']} already decoded (--force decodes again)" \
        if counts["skipped"] else ""
    decoded = counts["decoded"]
    restored = f", {again} of them again as files of theirs were gone from the dataset" \
        if again else ""
    same = _links_text(counts["same"], len(linked_to))
    click.echo(f"{decoded} file{'' if decoded == 1 else 's'} decoded to {out} ({frames:,} "
               f"frames in {elapsed:.1f} s){restored}{skipped}{same}", err=True)
    if counts["failed"]:
        raise click.ClickException(f"{counts['failed']} of {total} files could not be decoded "
                                   "(named above); the others are in the dataset")
