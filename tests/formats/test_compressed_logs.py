"""``decode``, ``convert`` and ``monitor --file`` read a compressed log (``.gz``, ``.zst``) of
every format that can be read front to back as they read it plain, decompressed as it is read
(bounded), as ``decode --parquet`` does; ``decode a.log.zst`` said "No read support for unknown
log format '.zst'". Without zstandard a ``.zst`` log is one line naming the extra."""

from __future__ import annotations

import gzip
import sys
import tracemalloc
from pathlib import Path

import pytest
import zstandard
from click.testing import CliRunner

from blinkcan.cli.extras import install_command
from blinkcan.cli.main import cli
from blinkcan.formats.logs import LogError, read_log

#: the formats read front to back (.db and .mf4 are files of their own: not read compressed)
FORMATS = [".log", ".asc", ".trc", ".csv", ".blf", ".pcap"]
COMPRESSIONS = [".gz", ".zst"]
LOG = "".join(f"({1_700_000_000 + n * 0.01:.6f}) can0 {line}\n" for n, line in enumerate(
    ["715#05", "70C#7F", "195#0100000000", "18FF0099#0102", "123#R", "70C#05"] * 20))


def _compress(path: Path, compression: str) -> Path:
    packed = path.with_name(path.name + compression)
    data = path.read_bytes()
    packed.write_bytes(gzip.compress(data) if compression == ".gz"
                       else zstandard.ZstdCompressor().compress(data))
    return packed


@pytest.fixture(scope="module")
def plain(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """The log in every format, as convert writes it."""
    folder = tmp_path_factory.mktemp("plain")
    source = folder / "trace.log"
    source.write_text(LOG)
    made = {".log": source}
    for suffix in FORMATS[1:]:
        made[suffix] = folder / f"trace{suffix}"
        result = CliRunner().invoke(cli, ["convert", str(source), str(made[suffix])])
        assert result.exit_code == 0, result.output
    return made


@pytest.mark.parametrize("compression", COMPRESSIONS)
@pytest.mark.parametrize("suffix", FORMATS)
def test_a_compressed_log_reads_as_the_plain_one(plain: dict[str, Path], tmp_path: Path,
                                                 suffix: str, compression: str) -> None:
    log = plain[suffix]
    packed = _compress(log, compression)
    for command in (["decode"], ["decode", "--json"]):
        result = CliRunner().invoke(cli, [*command, str(packed)])
        assert result.exit_code == 0, result.output
        assert result.stdout == CliRunner().invoke(cli, [*command, str(log)]).stdout
    converted = {}
    for name, source in (("plain", log), ("packed", packed)):
        converted[name] = tmp_path / f"{name}.log"
        result = CliRunner().invoke(cli, ["convert", str(source), str(converted[name])])
        assert result.exit_code == 0, result.output
    assert converted["packed"].read_text() == converted["plain"].read_text()
    assert len(converted["plain"].read_text().splitlines()) == 120
    # monitor --file reads with read_log
    assert [(t, str(f)) for t, f in read_log(packed)] == [(t, str(f)) for t, f in read_log(log)]


@pytest.mark.parametrize("command", [["decode"], ["convert", "-", "{tmp}/out.log"],
                                     ["monitor", "--speed", "0", "--file"]])
def test_without_zstandard_a_zst_log_is_one_line_naming_the_extra(
        plain: dict[str, Path], tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        command: list[str]) -> None:
    packed = _compress(plain[".log"], ".zst")
    monkeypatch.setitem(sys.modules, "zstandard", None)  # import zstandard: ImportError
    args = [arg.format(tmp=tmp_path) for arg in command]
    args = [str(packed) if arg == "-" else arg for arg in args]
    if command[0] != "convert":
        args.append(str(packed))
    result = CliRunner().invoke(cli, args)
    assert result.exit_code == 1, result.output
    lines = [line for line in result.output.splitlines() if line.startswith("Error: ")]
    assert len(lines) == 1, result.output
    assert "zstandard, which is not installed: it comes with blinkcan's [fleet] extra" in \
        lines[0]
    assert lines[0].endswith(f": {install_command('fleet')}")


@pytest.mark.parametrize("suffix", [".log", ".asc"])
def test_a_compressed_bomb_is_read_a_buffer_at_a_time(tmp_path: Path, suffix: str) -> None:
    """64 MiB of zeros in a few kilobytes: the first line's bound ends it, in bounded
    memory."""
    bomb = tmp_path / f"bomb{suffix}.zst"
    compressor = zstandard.ZstdCompressor()
    bomb.write_bytes(compressor.compress(b"0" * (64 << 20)))
    tracemalloc.start()
    try:
        with pytest.raises(LogError, match="line 1 is over 4096 bytes"):
            list(read_log(bomb))
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 8 << 20


def test_a_zst_log_cut_short_keeps_the_frames_before_the_cut(tmp_path: Path) -> None:
    """Cut inside its last block (a block, up to 128 KiB of text, decompresses only whole):
    every frame of the blocks before it is decoded, and the cut is named."""
    log = tmp_path / "long.log"
    log.write_text(LOG * 200)  # 24,000 frames, several blocks
    cut = tmp_path / "cut.log.zst"
    cut.write_bytes(_compress(log, ".zst").read_bytes()[:-40])
    result = CliRunner().invoke(cli, ["decode", "--json", str(cut)])
    assert result.exit_code == 0, result.output
    frames = [line for line in result.stdout.splitlines() if '"unreadable"' not in line]
    assert 10_000 < len(frames) < 24_000
    assert "before its compressed stream does: cut short" in result.stderr
