"""``blinkcan monitor --file`` without --device learns a node's model from a frame only that
model sends, as ``decode`` does (tests/cli/test_decode_learns_model.py): from that frame on,
every line is the one --device gives."""

from __future__ import annotations

from pathlib import Path

import pytest
from click.testing import CliRunner

from blinkcan.cli.main import cli
from blinkcan.devices.model import Model
from blinkcan.devices.registry import models
from tests.cli.test_decode_learns_model import mid_stream_capture


def _lines(log: Path, *options: str) -> list[str]:
    result = CliRunner().invoke(cli, ["monitor", "--file", str(log), "--speed", "0", *options])
    assert result.exit_code == 0, result.output
    return result.stdout.splitlines()


@pytest.mark.parametrize("model", models(), ids=lambda model: model.name)
def test_monitor_learns_a_model_from_a_frame_only_it_sends(tmp_path: Path, model: Model) -> None:
    log, first = mid_stream_capture(tmp_path, model)
    learned = _lines(log)
    named = _lines(log, "--device", f"{model.default_node_id:#x}={model.name}")
    assert len(learned) == len(named) == len(log.read_text().splitlines())
    assert learned[first:] == named[first:]
