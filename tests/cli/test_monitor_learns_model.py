"""``blinkcan monitor --file`` without --device learns a node's model from a frame only that
model sends, as ``decode`` does (tests/cli/test_decode_learns_model.py): from that frame on,
every line is the one --device gives."""

from __future__ import annotations

from pathlib import Path

import pytest
from click.testing import CliRunner

from blinkcan.cli.main import cli
from blinkcan.devices.model import Model
from blinkcan.devices.registry import describe_device, models
from blinkcan.protocol import Frame
from tests.cli.test_decode_learns_model import _own_bases
from tests.fleet.logs import EPOCH, candump_lines


def _lines(log: Path, *options: str) -> list[str]:
    result = CliRunner().invoke(cli, ["monitor", "--file", str(log), "--speed", "0", *options])
    assert result.exit_code == 0, result.output
    return result.stdout.splitlines()


@pytest.mark.parametrize("model", models(), ids=lambda model: model.name)
def test_monitor_learns_a_model_from_a_frame_only_it_sends(tmp_path: Path, model: Model) -> None:
    description = describe_device(model.name)
    own = _own_bases(description)
    if not own:
        pytest.skip(f"{model.name} sends no frame another model does not")
    node = model.default_node_id
    frames = [Frame(layout.cob_id(node), bytes((fill,) * layout.length))
              for fill in (0x00, 0x21, 0x00) for layout in description.pdos]
    log = tmp_path / "mid-stream.log"
    log.write_text("".join(candump_lines(
        [(EPOCH + n * 0.01, frame) for n, frame in enumerate(frames)])))
    learned = _lines(log)
    named = _lines(log, "--device", f"{node:#x}={model.name}")
    assert len(learned) == len(named) == len(frames)
    last = len(description.pdos)  # the last round of frames comes after the learning frame
    assert learned[-last:] == named[-last:]
