"""What `export` writes and where: a planted link is never replaced, `-o -` is stdout
(found by the newcomer/attacker pass of session 4)."""

from __future__ import annotations

from pathlib import Path

import pytest
from click.testing import CliRunner

from blinkcan.cli.main import cli


@pytest.mark.parametrize("arguments", [["export", "eds", "keypad", "-o"],
                                       ["export", "dbc", "keybox", "-o"], ["convert", "IN"]])
def test_a_dangling_symlink_at_the_target_is_refused_not_replaced(tmp_path: Path,
                                                                   arguments: list[str]) -> None:
    log = tmp_path / "in.log"
    log.write_text("(1.0) can0 715#00\n")
    link = tmp_path / "out.log"
    link.symlink_to(tmp_path / "elsewhere")  # a link whose target does not exist (yet)
    line = [str(log) if word == "IN" else word for word in arguments] + [str(link)]
    result = CliRunner().invoke(cli, line)
    assert result.exit_code == 1, result.output
    assert result.output.splitlines()[-1] == f"Error: {link} exists; pass --force to replace it"
    assert link.is_symlink()  # the user's link is still there


@pytest.mark.parametrize(("kind", "first"), [("eds", "[FileInfo]"), ("dbc", 'VERSION ""')])
def test_output_dash_is_standard_output(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                        kind: str, first: str) -> None:
    monkeypatch.chdir(tmp_path)
    result = CliRunner().invoke(cli, ["export", kind, "keypad", "-o", "-"])
    assert result.exit_code == 0, result.output
    assert result.stdout.splitlines()[0] == first
    assert not (tmp_path / "-").exists()  # no file named "-"
