"""decode_files on a Dask cluster: a LocalCluster of 2 worker processes writes the dataset one
process writes; a file that cannot be read fails alone; a worker killed in the middle of a
file leaves none of its rows, and the file is decoded again. Few and quick (one cluster)."""

from __future__ import annotations

import logging
import os
import signal
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
from distributed import Client, LocalCluster

from blinkcan.fleet import FileResult, decode_files
from blinkcan.fleet.task import source_key
from tests.fleet.logs import fleet_traffic, write_log
from tests.fleet.test_dataset import dataset_files


@pytest.fixture(scope="module")
def client() -> Iterator[Client]:
    with LocalCluster(n_workers=2, processes=True, threads_per_worker=1,  # type: ignore[no-untyped-call]
                      dashboard_address=None, silence_logs=logging.ERROR) as cluster, \
            Client(cluster) as dask_client:  # type: ignore[no-untyped-call]
        yield dask_client


def test_a_cluster_writes_the_dataset_one_process_writes(tmp_path: Path,
                                                         client: Client) -> None:
    logs = tmp_path / "logs"
    for unit, taps in (("boat-07", 3), ("boat-12", 5), ("boat-31", 1)):
        (logs / unit).mkdir(parents=True)
        write_log(logs / unit / "day.log.gz", fleet_traffic(taps))
    (logs / "boat-40").mkdir()
    (logs / "boat-40" / "day.blf").write_bytes(b"LOGG" + bytes(200))  # cannot be read
    alone = decode_files([logs], str(tmp_path / "alone"))
    spread = decode_files([logs], f"file://{tmp_path}/spread", client=client)
    assert [(r.source, r.status, r.frames, r.rows) for r in spread] == \
        [(r.source, r.status, r.frames, r.rows) for r in alone]
    assert [r.status for r in spread] == ["decoded"] * 3 + ["failed"]
    assert "not a readable log" in (spread[3].error or "")
    assert dataset_files(tmp_path / "spread") == dataset_files(tmp_path / "alone")
    assert len(dataset_files(tmp_path / "spread")) == 3 * 3 * 2  # 3 logs, 3 models, 2 dates


def test_a_worker_killed_mid_file_leaves_nothing_and_the_file_is_decoded_again(
        tmp_path: Path, client: Client) -> None:
    traffic = fleet_traffic(taps=3)
    log = write_log(tmp_path / "long.log", traffic * 8)  # frames repeat: only a longer log
    reference = decode_files([log], str(tmp_path / "alone"), rows_per_group=2_000)
    out = tmp_path / "spread"
    results: list[FileResult] = []
    runner = threading.Thread(target=lambda: results.extend(
        decode_files([log], str(out), client=client, rows_per_group=2_000)))
    runner.start()
    attempts = out / "_blinkcan" / "tmp"
    manifest = out / "_blinkcan" / f"{source_key(str(log))}.json"
    deadline = time.monotonic() + 20
    while not list(attempts.glob("*/model=*/date=*/*.parquet")) and time.monotonic() < deadline:
        time.sleep(0.005)  # the first row groups of the first attempt are on disk
    [dead] = list(attempts.iterdir())
    assert not manifest.exists()  # mid-file
    busy = client.processing()  # type: ignore[no-untyped-call]
    [worker] = [w for w, keys in busy.items() if keys]
    pid = client.run(os.getpid, workers=[worker])[worker]
    os.kill(pid, signal.SIGKILL)
    runner.join(timeout=25)
    assert not runner.is_alive()
    assert [(r.status, r.frames, r.rows) for r in results] == \
        [(r.status, r.frames, r.rows) for r in reference]
    assert dataset_files(out) == dataset_files(tmp_path / "alone")
    assert not dead.exists()
    assert manifest.exists()


def test_a_hard_link_given_alone_later_is_the_same_file_on_a_cluster(tmp_path: Path,
                                                                      client: Client) -> None:
    """As in one process (tests/fleet/test_linked_sources.py): the workers write the file's
    identity, the run finds the name it was decoded under; nothing is decoded twice."""
    first, second = tmp_path / "a.log", tmp_path / "b.log"
    write_log(first, fleet_traffic(2))
    out = f"file://{tmp_path}/spread"
    assert [r.status for r in decode_files([first], out, client=client)] == ["decoded"]
    os.link(first, second)
    again = decode_files([second], out, client=client)
    assert [(r.source, r.status, r.same_as) for r in again] == \
        [(str(first), "skipped", None), (str(second), "same", str(first))]
    decode_files([first], str(tmp_path / "alone"))
    assert dataset_files(tmp_path / "spread") == dataset_files(tmp_path / "alone")


def test_a_renamed_file_is_not_decoded_twice_on_a_cluster(tmp_path: Path,
                                                          client: Client) -> None:
    """As in one process (tests/fleet/test_renamed_sources.py): unchanged, the renamed file
    is skipped; grown, its rows replace the old name's."""
    first, second = tmp_path / "a.log", tmp_path / "b.log"
    write_log(first, fleet_traffic(2))
    out = f"file://{tmp_path}/spread"
    decode_files([first], out, client=client)
    first.rename(second)
    again = decode_files([second], out, client=client)
    assert [(r.source, r.status, r.same_as) for r in again] == \
        [(str(second), "skipped", str(first))]
    write_log(second, fleet_traffic(3))
    grown = decode_files([second], out, client=client)
    assert [(r.source, r.status) for r in grown] == [(str(second), "decoded")]
    decode_files([second], str(tmp_path / "alone"))
    assert dataset_files(tmp_path / "spread") == dataset_files(tmp_path / "alone")
