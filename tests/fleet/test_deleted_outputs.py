"""A partition file deleted from the dataset is decoded again on the next run, and the run says
so (found by the attack pass of session 5: the source was skipped as "already decoded" and
its rows were gone for good: data silently lost)."""

from __future__ import annotations

from pathlib import Path

import pyarrow.dataset as ds
from click.testing import CliRunner

from blinkcan.cli.main import cli
from blinkcan.fleet import decode_files
from tests.fleet.logs import fleet_traffic, write_log


def _rows(out: Path) -> int:
    return int(ds.dataset(out, format="parquet", partitioning="hive").count_rows())


def test_a_deleted_partition_file_is_decoded_again(tmp_path: Path) -> None:
    log = write_log(tmp_path / "unit-7.log", fleet_traffic())
    out = tmp_path / "lake"
    [first] = decode_files([log], str(out))
    rows = _rows(out)
    assert len(first.outputs) > 1  # several partitions: one is deleted, the others stay
    gone = first.outputs[0]
    (out / gone).unlink()
    assert _rows(out) < rows
    [second] = decode_files([log], str(out))
    assert second.status == "decoded"  # was "skipped": its rows lost for good
    assert second.missing == (gone,)
    assert (out / gone).exists()
    assert _rows(out) == rows  # every row back, none twice
    [third] = decode_files([log], str(out))
    assert (third.status, third.missing) == ("skipped", ())


def test_the_run_says_which_files_were_gone(tmp_path: Path) -> None:
    log = write_log(tmp_path / "unit-7.log", fleet_traffic())
    out = tmp_path / "lake"
    [first] = decode_files([log], str(out))
    (out / first.outputs[-1]).unlink()
    result = CliRunner().invoke(cli, ["decode", str(log), "--parquet", str(out)])
    assert result.exit_code == 0, result.output
    assert f"decoded again, 1 of its files were gone from the dataset: {first.outputs[-1]}" \
        in result.output
    assert "1 file decoded to" in result.output
    assert "1 of them again as files of theirs were gone from the dataset" in result.output
