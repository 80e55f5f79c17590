"""The examples of the README's command table run as written, with a virtual bus in place of
the interface they name (``-i/-c`` replaced), against twins: a keypad (15h), a generation-2 keypad
(16h), a PKP-3500-MT (17h) and a Keybox (0Ch). Commands that run until Ctrl-C or for a minute
(demo, emulate, live monitor, record) have tests of their own."""

from __future__ import annotations

import re
import shlex
import uuid
from pathlib import Path

import can
import pytest
from click.testing import CliRunner

from blinkcan.cli.main import cli
from blinkcan.formats.logs import FrameWriter
from blinkcan.runtime import Emulator
from blinkcan.twin import KeyboxTwin, KeypadTwin
from tests.cli.session import session
from tests.host.conftest import quiet_keypad

README = Path(__file__).resolve().parents[2] / "README.md"
RUN_ELSEWHERE = ("demo", "emulate", "monitor", "record")


def _examples() -> list[str]:
    table = README.read_text().split("## Command line", 1)[1].split("\n## ", 1)[0]
    rows = [line for line in table.splitlines() if line.startswith("| `")]
    examples = [example for row in rows for example in re.findall(r"`(blinkcan [^`]+)`", row)]
    return [e for e in examples if shlex.split(e)[1] not in RUN_ELSEWHERE]


def _on_virtual(words: list[str], channel: str) -> list[str]:
    kept: list[str] = []
    skip = False
    for word in words:
        if skip:
            skip = False
        elif word in ("-i", "-c", "--interface", "--channel"):
            skip = True
        else:
            kept.append(word)
    return [*kept, "-i", "virtual", "-c", channel]


def test_the_table_has_examples_of_every_command() -> None:
    commands = {shlex.split(e)[1] for e in _examples()}
    assert commands >= {"scan", "decode", "convert", "export", "keypad", "keybox", "nmt"}


@pytest.mark.parametrize("example", _examples())
def test_readme_command_example_runs(example: str, tmp_path: Path,
                                     monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    with FrameWriter("trace.log") as writer:
        for timestamp, frame in session():
            writer.write(timestamp, frame)
    channel = f"readme-{uuid.uuid4().hex}"
    bus = can.Bus(interface="virtual", channel=channel)
    twins = [quiet_keypad(), KeypadTwin(node_id=0x16, manual="1.5"),
             KeypadTwin(node_id=0x17, model="pkp-3500-mt"), KeyboxTwin()]
    words = shlex.split(example)[1:]
    if words[0] in ("keypad", "keybox", "nmt", "scan"):
        words = _on_virtual(words, channel)
    try:
        with Emulator(bus, twins):
            result = CliRunner().invoke(cli, words, input="y\n", env={"COLUMNS": "200"})
    finally:
        bus.shutdown()
    assert result.exit_code == 0, f"{example}: {result.output}"
