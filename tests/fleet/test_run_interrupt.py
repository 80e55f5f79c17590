"""Ctrl-C on `decode --parquet -j N`, and the parent of the workers killed (found by the
attack pass: each failed on main). Ctrl-C took 14-25 s to stop, going on with the files
still queued; a `kill -9` of the parent left the workers waiting forever."""

from __future__ import annotations

import contextlib
import multiprocessing.process
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

pytest.importorskip("pyarrow")

from blinkcan.fleet import run
from blinkcan.fleet.run import decode_files
from blinkcan.fleet.task import decode_file

LOG = "(1.000000) can0 715#00\n(1.100000) can0 195#0800000001\n"
#: how long the blocking file holds its worker unless something stops it
HOLD = 20.0


def _holding(source: str, **options: object) -> object:
    """The per-file task, but hold.log writes its pid to hold.started, (with
    $HOLD_INTERRUPTS) sends SIGINT to the parent as a terminal's Ctrl-C would, and holds its
    worker for HOLD seconds before it writes hold.finished. At module level: the pool sends
    the task to its workers by reference."""
    folder = Path(source).parent.parent  # beside the logs folder, not in it
    if source.endswith("hold.log"):
        (folder / "hold.started").write_text(str(os.getpid()))
        if os.environ.get("HOLD_INTERRUPTS"):
            os.kill(os.getppid(), signal.SIGINT)
        deadline = time.monotonic() + HOLD
        while time.monotonic() < deadline:
            time.sleep(0.05)
        (folder / "hold.finished").write_text("")
    return decode_file(source, **options)  # type: ignore[arg-type]


def _logs(folder: Path, others: int) -> Path:
    folder.mkdir()
    (folder / "hold.log").write_text(LOG)
    for n in range(others):
        (folder / f"z{n}.log").write_text(LOG)  # after hold.log in the run's order
    return folder


def _gone(pid: int) -> bool:
    """The process ended (a zombie nobody reaped counts: it runs nothing)."""
    try:
        status = Path(f"/proc/{pid}/status").read_text()
    except OSError:
        return True
    return "\nState:\tZ" in status


@pytest.mark.filterwarnings("error::pytest.PytestUnhandledThreadExceptionWarning")
@pytest.mark.parametrize("death_seen_first", [False, True])
def test_ctrl_c_stops_the_workers_and_starts_no_other_file(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, death_seen_first: bool) -> None:
    """No thread of the pool fails on the way either (an error here, not a warning): the run
    cancelled the queued files' futures itself, then stopped the workers; when the pool's
    manager thread saw a worker's death before the shutdown (now and then under load; always
    with ``death_seen_first``: a stop that waits for the worker to end) it failed setting
    BrokenProcessPool on a cancelled future (InvalidStateError), and a user's Ctrl-C printed
    that thread's traceback."""
    if death_seen_first:
        terminate = multiprocessing.process.BaseProcess.terminate

        def terminate_and_wait(process: multiprocessing.process.BaseProcess) -> None:
            terminate(process)
            process.join()
            time.sleep(0.2)  # the manager thread's turn

        monkeypatch.setattr(multiprocessing.process.BaseProcess, "terminate",
                            terminate_and_wait)
    logs = _logs(tmp_path / "logs", others=8)
    monkeypatch.setenv("HOLD_INTERRUPTS", "1")
    monkeypatch.setattr(run, "decode_file", _holding)
    heard: list[str] = []
    with pytest.raises(KeyboardInterrupt):
        decode_files([logs], str(tmp_path / "lake"), jobs=2,
                     on_result=lambda r: heard.append(os.path.basename(r.source)))
    assert (logs.parent / "hold.started").exists()
    # the file in flight is not waited for: its worker is stopped, its rows never appear
    assert not (logs.parent / "hold.finished").exists()
    assert _gone(int((logs.parent / "hold.started").read_text()))
    # and the files still queued were not started after the Ctrl-C
    assert len(heard) < 8, heard
    lake = tmp_path / "lake"
    # a run afterwards decodes every file, the interrupted one included
    monkeypatch.delenv("HOLD_INTERRUPTS")
    monkeypatch.setattr(sys.modules[__name__], "HOLD", 0.0)
    results = decode_files([logs], str(lake), jobs=2)
    assert {r.status for r in results} <= {"decoded", "skipped"}, results
    assert not list((lake / "_blinkcan" / "tmp").iterdir())


SCRIPT = """
import sys
sys.path.insert(0, {tests!r})
from blinkcan.fleet import run
import test_run_interrupt
run.decode_file = test_run_interrupt._holding
run.decode_files([{logs!r}], {lake!r}, jobs=2)
"""


def test_the_workers_end_when_the_process_that_runs_them_is_killed(tmp_path: Path) -> None:
    logs = _logs(tmp_path / "logs", others=3)
    script = SCRIPT.format(tests=str(Path(__file__).parent), logs=str(logs),
                           lake=str(tmp_path / "lake"))
    # a session of its own: whatever outlives the test is killed with its process group
    parent = subprocess.Popen([sys.executable, "-c", script], start_new_session=True)
    try:
        deadline = time.monotonic() + 60
        while not (logs.parent / "hold.started").exists() and time.monotonic() < deadline:
            assert parent.poll() is None, "the run ended before the file was held"
            time.sleep(0.05)
        worker = int((logs.parent / "hold.started").read_text())
        parent.kill()
        parent.wait()
        deadline = time.monotonic() + HOLD / 2
        while not _gone(worker) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert _gone(worker), "a worker outlived the run that started it"
        assert not (logs.parent / "hold.finished").exists()
    finally:
        parent.kill()
        parent.wait()
        with contextlib.suppress(ProcessLookupError):
            os.killpg(parent.pid, signal.SIGKILL)
