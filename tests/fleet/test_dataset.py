"""decode_files on one machine: the dataset's rows, formats, partitions, whole-or-nothing
output, skipping what is decoded, unreadable files, fsspec locations, the CLI."""

from __future__ import annotations

import gzip
import json
import os
import subprocess
import sys
from pathlib import Path
from typing import Any

import duckdb
import fsspec
import pyarrow as pa
import pyarrow.dataset as ds
import pyarrow.parquet as pq
import pytest
from click.testing import CliRunner

from blinkcan.cli.extras import install_command
from blinkcan.cli.main import cli
from blinkcan.devices.registry import describe_device
from blinkcan.fleet import decode_files
from blinkcan.fleet.query import connect
from blinkcan.fleet.schema import SCHEMA
from blinkcan.fleet.task import source_key
from blinkcan.protocol import Frame
from tests.fleet.logs import EPOCH, Traffic, candump_lines, fleet_traffic, write_log

#: the columns that say what happened (not where it was logged)
MEANING = ["can_id", "extended", "node", "kind", "key", "pin", "state", "colour", "value",
           "text", "data"]


@pytest.fixture(scope="module")
def traffic() -> Traffic:
    return fleet_traffic()


def dataset_files(out: Path) -> dict[str, pa.Table]:
    """Every data file of a dataset (relative path -> its table)."""
    return {str(p.relative_to(out)): pq.read_table(p)
            for p in sorted(out.glob("model=*/date=*/*.parquet"))}


def events(out: Path, sql: str) -> list[tuple[Any, ...]]:
    with connect(str(out)) as connection:
        return connection.execute(sql).fetchall()


def test_the_dataset_has_a_row_per_event_by_model_and_date(tmp_path: Path, traffic: Traffic
                                                          ) -> None:
    (tmp_path / "logs").mkdir()
    log = write_log(tmp_path / "logs" / "unit-7.log", traffic)
    [result] = decode_files([log], str(tmp_path / "lake"))
    assert (result.status, result.frames) == ("decoded", len(traffic))
    table = ds.dataset(tmp_path / "lake", format="parquet", partitioning="hive").to_table()
    assert table.schema.names == [*SCHEMA.names, "model", "date"]
    assert pq.read_schema(next((tmp_path / "lake").glob("model=*/date=*/*.parquet"))) \
        .equals(SCHEMA)
    # every frame is at least one row; the devices' rows are by model, foreign ones unknown
    assert table.num_rows >= len(traffic)
    assert set(table.column("model").to_pylist()) == {"pkp-2600-si", "keybox", "unknown"}
    assert set(table.column("date").to_pylist()) == {"2026-05-31", "2026-06-01"}
    assert events(tmp_path / "lake", "SELECT key, state, count(*) FROM events WHERE "
                  "kind = 'key' AND key IS NOT NULL GROUP BY ALL ORDER BY ALL") == \
        [(1, "pressed", 2), (1, "released", 2), (2, "pressed", 1), (2, "released", 1)]
    assert events(tmp_path / "lake", "SELECT model, node, pin, state FROM events "
                  "WHERE kind = 'fault' AND pin IS NOT NULL") == [("keybox", 12, 4, "fault")]
    first = events(tmp_path / "lake", "SELECT time, source, channel, can_id, data FROM events "
                   f"WHERE can_id = {traffic[0][1].can_id} ORDER BY time LIMIT 1")[0]
    assert first[0].timestamp() == pytest.approx(traffic[0][0])
    assert first[1:] == (str(log), "can0", traffic[0][1].can_id, traffic[0][1].data)
    # the foreign frames are there, undecoded, with their identifiers
    assert events(tmp_path / "lake", "SELECT count(*) FROM events WHERE extended AND "
                  "kind = 'undecoded'") == [(320,)]


def test_a_lost_heartbeat_shows_as_a_gap(tmp_path: Path, traffic: Traffic) -> None:
    log = write_log(tmp_path / "unit.log", traffic)
    decode_files([log], str(tmp_path / "lake"))
    gaps = events(tmp_path / "lake", """
        SELECT node, count(*) FROM (
            SELECT node, time - lag(time) OVER (PARTITION BY source, node ORDER BY time) AS gap
            FROM events WHERE kind = 'heartbeat')
        WHERE gap > INTERVAL 500 MILLISECOND GROUP BY node""")
    assert gaps == [(0x15, 1)]


FORMATS = [".log.gz", ".log.zst", ".pcap", ".blf", ".asc", ".csv", ".trc", ".db"]


@pytest.mark.parametrize("suffix", FORMATS)
def test_every_format_convert_reads_gives_the_same_events(tmp_path: Path, traffic: Traffic,
                                                          suffix: str) -> None:
    reference = write_log(tmp_path / "reference.log", traffic)
    other = write_log(tmp_path / f"other{suffix}", traffic)
    decode_files([reference, other], str(tmp_path / "lake"))
    rows = {}
    for source in (reference, other):
        table = ds.dataset(tmp_path / "lake", format="parquet", partitioning="hive") \
            .to_table(filter=ds.field("source") == str(source))
        rows[source] = table.sort_by([("time", "ascending")]).select(MEANING).to_pylist()
    assert rows[other] == rows[reference]


@pytest.mark.parametrize("suffix", [".asc", ".asc.gz"])
def test_asc_rows_keep_their_absolute_times_and_dates(tmp_path: Path, traffic: Traffic,
                                                      suffix: str) -> None:
    """ASC times count from the file's start date: read by blinkcan's reader, not python-can's
    relative times (which put every row on 1970-01-01)."""
    log = write_log(tmp_path / f"unit{suffix}", traffic)
    decode_files([log], str(tmp_path / "lake"))
    table = ds.dataset(tmp_path / "lake", format="parquet", partitioning="hive").to_table()
    assert set(table.column("date").to_pylist()) == {"2026-05-31", "2026-06-01"}
    times = sorted(t.timestamp() for t in table.column("time").to_pylist())
    assert times[0] == pytest.approx(traffic[0][0], abs=1e-3)
    assert times[-1] == pytest.approx(traffic[-1][0], abs=1e-3)


def test_mf4_through_asammdf(tmp_path: Path, traffic: Traffic) -> None:
    pytest.importorskip("asammdf")
    reference = write_log(tmp_path / "reference.log", traffic[:200])
    other = write_log(tmp_path / "other.mf4", traffic[:200])
    results = decode_files([reference, other], str(tmp_path / "lake"))
    assert [r.status for r in results] == ["decoded", "decoded"]
    assert results[0].rows == results[1].rows


def test_a_file_decoded_is_skipped_until_it_changes_or_force(tmp_path: Path, traffic: Traffic
                                                            ) -> None:
    log = write_log(tmp_path / "unit.log", traffic[:1000])
    out = str(tmp_path / "lake")
    assert decode_files([log], out)[0].status == "decoded"
    before = dataset_files(tmp_path / "lake")
    assert decode_files([log], out)[0].status == "skipped"
    assert decode_files([log], out, force=True)[0].status == "decoded"
    assert dataset_files(tmp_path / "lake") == before
    # the log grows (a logger still writing): decoded again, its rows once, none stale
    with log.open("a") as stream:
        stream.writelines(candump_lines(traffic[1000:]))
    os.utime(log, ns=(log.stat().st_atime_ns, log.stat().st_mtime_ns + 1_000_000_000))
    [result] = decode_files([log], out)
    assert (result.status, result.frames) == ("decoded", len(traffic))
    assert events(tmp_path / "lake", "SELECT count(DISTINCT time) FROM events")[0][0] == \
        len({t for t, _ in traffic})
    manifest = json.loads((tmp_path / "lake" / "_blinkcan" / f"{source_key(str(log))}.json")
                          .read_text())
    assert (manifest["frames"], manifest["source"]) == (len(traffic), str(log))
    assert sorted(manifest["outputs"]) == sorted(dataset_files(tmp_path / "lake"))


def test_an_unreadable_file_is_named_and_skipped_and_leaves_nothing(tmp_path: Path,
                                                                    traffic: Traffic) -> None:
    good = write_log(tmp_path / "good.log", traffic)
    garbage = tmp_path / "garbage.blf"
    garbage.write_bytes(b"LOGG" + bytes(300))
    # a log that fails after its first row groups are written (a .gz whose checksum is
    # wrong: its data is not what was compressed; a compressed log cut short keeps its frames
    # before the cut: tests/fleet/test_compressed_cut.py; a line over MAX_LINE is one
    # unreadable line: tests/formats/test_read_on.py)
    cut = tmp_path / "cut.log.gz"
    cut.write_bytes(gzip.compress("".join(candump_lines(traffic)).encode())[:-8] + bytes(8))
    results = decode_files([garbage, cut, good], str(tmp_path / "lake"), rows_per_group=100)
    assert [r.status for r in results] == ["failed", "failed", "decoded"]
    assert results[0].source == str(garbage)
    assert "not a readable log" in (results[0].error or "")
    assert "CRC check failed" in (results[1].error or "")
    assert {t.column("source")[0].as_py() for t in dataset_files(tmp_path / "lake").values()} \
        == {str(good)}
    meta = tmp_path / "lake" / "_blinkcan"
    assert sorted(p.name for p in meta.iterdir() if p.is_file()) == \
        [f"{source_key(str(good))}.json"]
    assert not list((meta / "tmp").iterdir())


def test_what_a_dead_run_left_is_cleared_before_decoding(tmp_path: Path, traffic: Traffic
                                                         ) -> None:
    log = write_log(tmp_path / "unit.log", traffic[:500])
    out = tmp_path / "lake"
    decode_files([log], str(out))
    clean = dataset_files(out)
    key = source_key(str(log))
    # a run died while renaming: a journal naming a half-moved file, and its attempt folder
    half = out / "model=keybox" / "date=2026-06-02" / f"{key}.parquet"
    half.parent.mkdir(parents=True)
    half.write_bytes(b"PAR1 half")
    (out / "_blinkcan" / f"{key}.pending.json").write_text(json.dumps(
        {"outputs": [str(half.relative_to(out))]}))
    attempt = out / "_blinkcan" / "tmp" / f"{key}-dead"
    attempt.mkdir(parents=True)
    (attempt / "x.parquet").write_bytes(b"PAR1")
    assert decode_files([log], str(out))[0].status == "decoded"
    assert dataset_files(out) == clean
    assert not half.exists()
    assert not attempt.exists()


@pytest.mark.parametrize("url", ["memory://fleet-test/lake", "file://{tmp}/lake2"])
def test_any_fsspec_location_holds_the_same_dataset(tmp_path: Path, traffic: Traffic,
                                                    url: str) -> None:
    log = write_log(tmp_path / "unit.log", traffic)
    decode_files([log], str(tmp_path / "lake"))
    url = url.format(tmp=tmp_path)
    decode_files([log], url)
    fs, root = fsspec.core.url_to_fs(url)
    try:
        theirs = {path[len(root) + 1:]: pq.read_table(path, filesystem=fs)
                  for path in sorted(fs.glob(f"{root}/model=*/date=*/*.parquet"))}
        assert theirs == dataset_files(tmp_path / "lake")
        with connect(url) as connection:
            assert connection.execute("SELECT count(*) FROM events").fetchone() == \
                (sum(t.num_rows for t in theirs.values()),)
    finally:
        fs.rm(root, recursive=True)


def test_local_processes_write_the_same_dataset(tmp_path: Path, traffic: Traffic) -> None:
    logs = [write_log(tmp_path / f"unit-{n}.log", traffic[n * 100:]) for n in range(3)]
    one = decode_files(logs, str(tmp_path / "one"))
    two = decode_files(logs, str(tmp_path / "two"), jobs=2)
    assert [r.rows for r in one] == [r.rows for r in two]
    assert dataset_files(tmp_path / "one") == dataset_files(tmp_path / "two")


# -- the command line ---------------------------------------------------------------------------


def test_decode_parquet_and_query_on_the_command_line(tmp_path: Path, traffic: Traffic) -> None:
    (tmp_path / "logs").mkdir()
    write_log(tmp_path / "logs" / "unit.log.zst", traffic)
    (tmp_path / "logs" / "broken.blf").write_bytes(b"not a log")
    out = str(tmp_path / "lake")
    result = CliRunner().invoke(cli, ["decode", str(tmp_path / "logs"), "--parquet", out,
                                      "-j", "2"])
    assert result.exit_code == 1
    assert f"cannot decode {tmp_path / 'logs' / 'broken.blf'}: " in result.output
    assert result.output.strip().splitlines()[-1] == (
        "Error: 1 of 2 files could not be decoded (named above); the others are in the dataset")
    sql = "SELECT key, count(*) AS presses FROM events WHERE state = 'pressed' GROUP BY key " \
          "ORDER BY key"
    as_csv = CliRunner().invoke(cli, ["query", out, sql, "--csv"])
    assert as_csv.exit_code == 0, as_csv.output
    assert as_csv.stdout == "key,presses\n1,2\n2,1\n"
    as_json = CliRunner().invoke(cli, ["query", out, sql, "--json"])
    assert [json.loads(line) for line in as_json.stdout.splitlines()] == \
        [{"key": 1, "presses": 2}, {"key": 2, "presses": 1}]
    table = CliRunner().invoke(cli, ["query", out, sql], env={"COLUMNS": "100"})
    assert "presses" in table.stdout
    assert "│ 1   │ 2" in table.stdout
    again = CliRunner().invoke(cli, ["decode", str(tmp_path / "logs" / "unit.log.zst"),
                                     "--parquet", out])
    assert again.exit_code == 0
    assert "1 already decoded" in again.output
    bad = CliRunner().invoke(cli, ["query", out, "SELECT nothing FROM events"])
    assert bad.exit_code == 1
    assert bad.output.startswith("Error: ")


@pytest.mark.parametrize("sql", [
    "COPY (SELECT * FROM events) TO '{out}/../stolen.csv'",
    "SELECT 1; COPY (SELECT 1) TO '{out}/../stolen.csv'",
    "EXPLAIN ANALYZE COPY (SELECT 1) TO '{out}/../stolen.csv'",
    "ATTACH '{out}/../stolen.db'",
    "EXPORT DATABASE '{out}/../stolen'",
    "COPY (SELECT 1 AS a) TO '{out}/{first}'",
])
def test_query_only_reads(tmp_path: Path, traffic: Traffic, sql: str) -> None:
    out = tmp_path / "lake"
    decode_files([write_log(tmp_path / "unit.log", traffic)], str(out))
    before = dataset_files(out)
    first = sorted(before)[0]
    result = CliRunner().invoke(cli, ["query", str(out), sql.format(out=out, first=first)])
    assert result.exit_code == 1
    assert result.output.startswith("Error: query only reads")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["lake", "unit.log"]
    assert dataset_files(out) == before
    described = CliRunner().invoke(cli, ["query", str(out), "DESCRIBE events", "--csv"])
    assert described.exit_code == 0, described.output
    assert "can_id" in described.stdout


def test_query_refusal_names_the_statement_the_user_wrote(tmp_path: Path,
                                                          traffic: Traffic) -> None:
    """DuckDB calls INSTALL a LOAD statement: the error quotes what the user typed."""
    out = tmp_path / "lake"
    decode_files([write_log(tmp_path / "unit.log", traffic)], str(out))
    result = CliRunner().invoke(cli, ["query", str(out), "SELECT 1; INSTALL httpfs"])
    assert result.exit_code == 1
    assert result.output.startswith("Error: query only reads: 'INSTALL httpfs' is not a SELECT")


@pytest.mark.parametrize("reader", ["read_csv('{secret}')", "read_text('{secret}')",
                                    "glob('{outside}/*')", "read_csv('{out}/../secret.csv')",
                                    "read_text('https://example.com/')"])
def test_query_reads_the_dataset_and_nothing_else(tmp_path: Path, traffic: Traffic,
                                                  reader: str) -> None:
    out = tmp_path / "lake"
    decode_files([write_log(tmp_path / "unit.log", traffic)], str(out))
    (tmp_path / "secret.csv").write_text("password\nhunter2\n")
    sql = "SELECT * FROM " + reader.format(secret=tmp_path / "secret.csv", outside=tmp_path,
                                           out=out)
    result = CliRunner().invoke(cli, ["query", str(out), sql, "--csv"])
    assert result.exit_code == 1, result.output
    assert result.output.startswith(f"Error: query reads only the dataset {out}: ")
    assert "hunter2" not in result.output
    assert "unit.log" not in result.output
    allowed = CliRunner().invoke(cli, ["query", str(out), "SELECT count(*) AS n FROM events",
                                       "--csv"])
    assert allowed.exit_code == 0, allowed.output


def test_a_connection_cannot_lift_its_confinement(tmp_path: Path, traffic: Traffic) -> None:
    out = tmp_path / "lake"
    decode_files([write_log(tmp_path / "unit.log", traffic)], str(out))
    with connect(str(out)) as connection:
        for setting in ("SET enable_external_access = true",
                        "SET allowed_directories = ['/']"):
            with pytest.raises(duckdb.Error):
                connection.execute(setting)
        [(count,)] = connection.execute("SELECT count(*) FROM events").fetchall()
        assert count > 1000


def test_query_names_a_folder_with_no_dataset(tmp_path: Path) -> None:
    result = CliRunner().invoke(cli, ["query", str(tmp_path), "SELECT 1"])
    assert result.exit_code == 1
    assert result.output == f"Error: {tmp_path}: no decoded events there (blinkcan decode LOG " \
        f"--parquet {tmp_path} writes them)\n"


def test_without_the_extra_parquet_says_how_to_install_it(tmp_path: Path,
                                                          monkeypatch: pytest.MonkeyPatch
                                                          ) -> None:
    from blinkcan import fleet

    monkeypatch.setattr(fleet, "missing", lambda *names: ["pyarrow"])
    log = write_log(tmp_path / "unit.log", [(EPOCH, fleet_traffic()[0][1])])
    result = CliRunner().invoke(cli, ["decode", str(log), "--parquet", str(tmp_path / "x")])
    assert result.exit_code == 1
    assert result.output == f"Error: --parquet needs pyarrow: {install_command('fleet')}\n"
    assert not (tmp_path / "x").exists()


def test_decode_without_parquet_imports_none_of_the_extra(tmp_path: Path) -> None:
    log = write_log(tmp_path / "unit.log", fleet_traffic()[:20])
    code = ("import sys\nfrom blinkcan.cli.main import main\nsys.argv = ['blinkcan', 'decode', "
            f"{str(log)!r}]\ntry:\n    main()\nexcept SystemExit:\n    pass\n"
            "loaded = sorted({'pyarrow', 'duckdb', 'dask', 'distributed', 'fsspec'} & "
            "{m.split('.')[0] for m in sys.modules})\nprint('LOADED', loaded, file=sys.stderr)")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                            check=False)
    assert "LOADED []" in result.stderr, result.stderr


def test_several_files_need_parquet(tmp_path: Path) -> None:
    result = CliRunner().invoke(cli, ["decode", "a.log", "b.log"])
    assert result.exit_code == 2
    assert "several files, -j and --force go with --parquet OUT" in result.output


def test_duckdb_reads_the_files_without_blinkcan(tmp_path: Path, traffic: Traffic) -> None:
    log = write_log(tmp_path / "unit.log", traffic)
    decode_files([log], str(tmp_path / "lake"))
    relation = duckdb.sql(f"SELECT count(*) FROM read_parquet('{tmp_path}/lake/*/*/*.parquet'"
                            ", hive_partitioning = true) WHERE model = 'keybox'")
    assert relation is not None
    [(count,)] = relation.fetchall()
    assert count > 1000


def _rows(out: Path) -> list[dict[str, Any]]:
    table = ds.dataset(out, format="parquet", partitioning="hive").to_table()
    rows: list[dict[str, Any]] = table.sort_by([
        ("time", "ascending"), ("can_id", "ascending"), ("kind", "ascending"),
        ("key", "ascending"), ("pin", "ascending")]).to_pylist()
    return rows


def test_row_groups_of_any_size_hold_the_same_rows(tmp_path: Path, traffic: Traffic) -> None:
    """Rows are gathered a block of frames at a time: a row group may end inside a block, or
    after any frame of several rows; the rows are the same."""
    log = write_log(tmp_path / "unit.log", traffic[:400] + traffic[-400:])  # two dates
    whole = decode_files([log], str(tmp_path / "whole"))
    assert all(pq.ParquetFile(tmp_path / "whole" / p).num_row_groups == 1
               for p in dataset_files(tmp_path / "whole"))
    for size in (1, 7, 300):
        [result] = decode_files([log], str(tmp_path / f"by-{size}"), rows_per_group=size)
        assert result.rows == whole[0].rows
        assert _rows(tmp_path / f"by-{size}") == _rows(tmp_path / "whole")
        groups = [pq.ParquetFile(tmp_path / f"by-{size}" / p).metadata
                  for p in dataset_files(tmp_path / f"by-{size}")]
        assert sum(g.num_row_groups for g in groups) > len(groups)
        assert max(g.row_group(n).num_rows for g in groups for n in range(g.num_row_groups)) \
            <= size + 24  # a row group ends at the frame that fills it


def test_remote_error_and_fd_frames_among_data_frames(tmp_path: Path, traffic: Traffic
                                                      ) -> None:
    """Frames that are not classic data frames (python-can's messages in the reader's columns)
    are rows at their place, with what their event says."""
    lines = list(candump_lines(traffic[:300]))
    odd = {10: "({t:.6f}) can1 70C#R\n", 11: "({t:.6f}) can0 20000004#0000080000000000\n",
           150: "({t:.6f}) can0 123##1AABBCCDDEEFF00112233\n"}
    for place in sorted(odd, reverse=True):
        lines.insert(place, odd[place].format(t=traffic[place][0]))
    log = tmp_path / "odd.log"
    log.write_text("".join(lines))
    for size in (3, 65_536):
        out = tmp_path / f"lake-{size}"
        [result] = decode_files([log], str(out), rows_per_group=size)
        assert result.frames == 303
        found = events(out, "SELECT channel, can_id, extended, kind, text, data FROM events "
                       "WHERE kind IN ('remote', 'error') OR text LIKE '%CAN FD%' ORDER BY time, "
                       "kind")
        assert found == [  # the first two at one time: by kind
            ("can0", 0x4, True, "error", "error frame: controller problem", bytes.fromhex(
                "0000080000000000")),
            ("can1", 0x70C, False, "remote", "keybox 0Ch: node guarding request", b""),
            ("can0", 0x123, False, "undecoded", "CAN FD frame 123h, 10 bytes (CAN FD is not "
             "decoded)", bytes.fromhex("AABBCCDDEEFF0011")),
        ]
    assert _rows(tmp_path / "lake-3") == _rows(tmp_path / "lake-65536")


def test_a_frame_says_who_sent_it_once_its_node_is_known(tmp_path: Path) -> None:
    """A node learned from its identity (1000h) names the device in the text of the frames
    the decoder still cannot decode (the same text is not reused for them)."""
    entry = describe_device("keypad").table.get(0x1000, 0)
    assert entry is not None
    assert isinstance(entry.default, int)
    reply = bytes((0x43, 0x00, 0x10, 0x00)) + entry.default.to_bytes(4, "little")
    frames = [Frame(0x08A, b"\x01"), Frame(0x60A, bytes.fromhex("4000100000000000")),
              Frame(0x58A, reply), Frame(0x08A, b"\x01")]
    log = write_log(tmp_path / "learn.log", [(EPOCH + n, f) for n, f in enumerate(frames)])
    decode_files([log], str(tmp_path / "lake"), devices={0x15: "keypad"})
    texts = events(tmp_path / "lake", "SELECT text FROM events WHERE can_id = 138 ORDER BY time")
    assert texts == [("node 0Ah: frame 08Ah",), ("keypad 0Ah: frame 08Ah",)]
