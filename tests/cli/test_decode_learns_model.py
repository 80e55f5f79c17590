"""``blinkcan decode`` without --device, on a capture that starts mid-stream (no identity
traffic): a node's model is learned from a frame only that model sends (a TPDO no other
registered model's PDO uses), so from that frame on every line is the one --device gives."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from click.testing import CliRunner

from blinkcan.cli.main import cli
from blinkcan.devices.model import DeviceDescription, Model
from blinkcan.devices.pdo import Direction
from blinkcan.devices.registry import default_descriptions, describe_device, models
from blinkcan.protocol import Frame
from tests.fleet.logs import EPOCH, candump_lines


def _own_bases(description: DeviceDescription) -> list[int]:
    """The COB-ID bases the model transmits that no other registered model's PDO uses."""
    others = {layout.cob_base for d in default_descriptions() if d.model != description.model
              for layout in d.pdos}
    return [layout.cob_base for layout in description.pdos
            if layout.direction is Direction.TX and layout.cob_base not in others]


def _lines(log: Path, *options: str) -> list[dict[str, object]]:
    result = CliRunner().invoke(cli, ["decode", str(log), "--json", *options])
    assert result.exit_code == 0, result.output
    return [json.loads(line) for line in result.stdout.splitlines()]


def mid_stream_capture(folder: Path, model: Model) -> tuple[Path, int]:
    """A capture of the model's PDOs at its default node with no identity traffic (three
    rounds), and the position of its first frame no other model sends; skips the test for a
    model that sends no such frame."""
    description = describe_device(model.name)
    own = _own_bases(description)
    if not own:
        pytest.skip(f"{model.name} sends no frame another model does not")
    node = model.default_node_id
    frames = [Frame(layout.cob_id(node), bytes((fill,) * layout.length))
              for fill in (0x00, 0x21, 0x00) for layout in description.pdos]
    log = folder / "mid-stream.log"
    log.write_text("".join(candump_lines(
        [(EPOCH + n * 0.01, frame) for n, frame in enumerate(frames)])))
    return log, next(n for n, frame in enumerate(frames) if frame.can_id - node in own)


@pytest.mark.parametrize("model", models(), ids=lambda model: model.name)
def test_decode_learns_a_model_from_a_frame_only_it_sends(tmp_path: Path, model: Model) -> None:
    log, first = mid_stream_capture(tmp_path, model)
    node = model.default_node_id
    learned = _lines(log)
    named = _lines(log, "--device", f"{node:#x}={model.name}")
    assert learned[first:] == named[first:]
