"""The garbage collector at start-up and while decode --parquet runs (issue 23: CPU per
frame): paused while a subcommand's modules are imported, frozen and collected less often
while logs are decoded; as it was afterwards, whatever happened."""

from __future__ import annotations

import gc
import sys
from pathlib import Path
from typing import Any

import pytest
from click.testing import CliRunner

from blinkcan import fleet
from blinkcan.cli import main as cli_main
from blinkcan.cli.collector import DECODING_THRESHOLD, collector_for_decoding, collector_paused


def test_a_subcommand_is_imported_with_the_collector_paused(tmp_path: Path,
                                                            monkeypatch: pytest.MonkeyPatch
                                                            ) -> None:
    (tmp_path / "probe_collector_command.py").write_text(
        "import gc\nimport click\nENABLED = gc.isenabled()\ncommand = click.Command('probe')\n")
    (tmp_path / "probe_collector_broken.py").write_text("raise ImportError('broken')\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setitem(cli_main.SUBCOMMANDS, "probe", ("probe_collector_command:command", "P"))
    monkeypatch.setitem(cli_main.SUBCOMMANDS, "broken", ("probe_collector_broken:command", "B"))
    try:
        assert cli_main.load_subcommand("probe").name == "probe"
        assert sys.modules["probe_collector_command"].ENABLED is False
        assert gc.isenabled()
        with pytest.raises(ImportError, match="broken"):
            cli_main.load_subcommand("broken")
        assert gc.isenabled()
    finally:
        sys.modules.pop("probe_collector_command", None)


def test_a_paused_collector_stays_off_where_it_was_off() -> None:
    gc.disable()
    try:
        with collector_paused():
            assert not gc.isenabled()
        assert not gc.isenabled()
    finally:
        gc.enable()


def test_decoding_runs_frozen_and_restores_the_collector_even_on_an_error() -> None:
    thresholds, frozen = gc.get_threshold(), gc.get_freeze_count()
    seen: list[tuple[tuple[int, ...], int]] = []

    def interrupted() -> None:
        with collector_for_decoding():
            seen.append((gc.get_threshold(), gc.get_freeze_count()))
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        interrupted()
    assert seen[0][0] == (DECODING_THRESHOLD, *thresholds[1:])
    assert seen[0][1] > frozen
    assert (gc.get_threshold(), gc.get_freeze_count()) == (thresholds, frozen)


def test_decode_to_parquet_decodes_with_the_collector_set_and_restores_it(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    if fleet.missing():
        pytest.skip(f"the fleet extra is not installed: {fleet.EXTRA}")
    from blinkcan.fleet import run

    log = tmp_path / "unit.log"
    log.write_text("(1700000000.000000) can0 715#05\n(1700000000.100000) can0 123#0102\n")
    seen: list[tuple[int, int]] = []
    decode_files = run.decode_files

    def watched(*args: Any, **kwargs: Any) -> Any:
        seen.append((gc.get_threshold()[0], gc.get_freeze_count()))
        return decode_files(*args, **kwargs)

    monkeypatch.setattr(run, "decode_files", watched)
    thresholds, frozen = gc.get_threshold(), gc.get_freeze_count()
    result = CliRunner().invoke(cli_main.cli, ["decode", str(log), "--parquet",
                                               str(tmp_path / "lake")])
    assert result.exit_code == 0, result.output
    assert seen[0][0] == DECODING_THRESHOLD
    assert seen[0][1] > frozen
    assert (gc.get_threshold(), gc.get_freeze_count()) == (thresholds, frozen)
    assert list((tmp_path / "lake").glob("model=*/date=*/*.parquet"))
