"""Start-up (issue 22): a subcommand's module, python-can and the runtime load when a command
needs them, so ``blinkcan --help`` and decoding a candump log start light."""

from __future__ import annotations

import gzip
import json
import subprocess
import sys
from pathlib import Path

import click
import pytest

from blinkcan.cli.main import SUBCOMMANDS, cli, load_subcommand

HEAVY = ("can", "cantools", "canopen", "rich.console", "blinkcan.runtime", "blinkcan.host",
         "blinkcan.twin")
PROBE = """
import json, sys
from blinkcan.cli.main import cli
try:
    cli.main(sys.argv[1:], prog_name="blinkcan", standalone_mode=False)
except SystemExit:
    pass
print(json.dumps(sorted(name for name in {heavy} if name in sys.modules)), file=sys.stderr)
"""


def _loaded_by(*args: str) -> list[str]:
    run = subprocess.run([sys.executable, "-c", PROBE.format(heavy=HEAVY), *args],
                         capture_output=True, text=True, check=True, timeout=60)
    loaded: list[str] = json.loads(run.stderr.strip().splitlines()[-1])
    return loaded


def test_help_loads_no_subcommand_and_no_bus() -> None:
    assert _loaded_by("--help") == []


def test_decoding_a_candump_log_loads_no_bus(tmp_path: Path) -> None:
    log = tmp_path / "ten.log"
    log.write_text("(1700000000.000000) can0 715#05\n(1700000000.000100) can0 18EFFF21#041B0103"
                   "0121FFFF\n")
    assert _loaded_by("decode", str(log)) == []
    assert _loaded_by("decode", "--json", str(log)) == []


@pytest.mark.parametrize("name", sorted(SUBCOMMANDS))
def test_the_listing_says_what_each_subcommand_says_of_itself(name: str) -> None:
    command = load_subcommand(name)
    listed = click.Command(name, help=SUBCOMMANDS[name][1])
    for limit in (30, 45, 74, 200):
        assert listed.get_short_help_str(limit) == command.get_short_help_str(limit)
    assert cli.get_command(click.Context(cli), name) is command


@pytest.mark.parametrize("as_json", [False, True])
def test_lines_decoded_before_a_broken_line_are_written(tmp_path: Path, as_json: bool) -> None:
    """Lines are written in batches (issue 22): those decoded before an error still come out,
    before the error's one line (a .gz whose checksum is wrong ends the reading: its data is
    not what was compressed; a line that is no frame does not, issue 23)."""
    from click.testing import CliRunner

    log = tmp_path / "broken.log.gz"
    lines = "".join(f"(1700000000.{n:06d}) can0 715#05\n(1700000000.{n:06d}) can0 70C#7F\n"
                    for n in range(2000))
    log.write_bytes(gzip.compress(lines.encode())[:-8] + bytes(8))  # checksum and size 0
    result = CliRunner().invoke(cli, ["decode", *(["--json"] if as_json else []), str(log)])
    assert result.exit_code == 1
    assert result.stderr.splitlines()[-1].startswith("Error: ")
    assert "CRC check failed" in result.stderr.splitlines()[-1]
    decoded = result.stdout.splitlines()
    assert 1000 < len(decoded) < 4000  # the 64 KiB chunk the error came in is not text
    assert all("715" in line for line in decoded[::2]) if not as_json else \
        [json.loads(line)["id"] for line in decoded[:4]] == [0x715, 0x70C] * 2
