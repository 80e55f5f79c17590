"""The README's twin examples run as written and send what their comments say."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

README = Path(__file__).resolve().parents[2] / "README.md"


def test_readme_twin_examples_run_as_written(capsys: pytest.CaptureFixture[str]) -> None:
    text = README.read_text()
    section = text[text.index("## A keypad twin in ten lines"):text.index("## Command line")]
    blocks = re.findall(r"```python\n(.*?)```", section, re.S)
    assert len(blocks) == 3
    namespace: dict[str, object] = {}
    for block in blocks:
        exec(compile(block, "README.md", "exec"), namespace)
    assert "'pressed': True" in capsys.readouterr().out
    host = namespace["host"]
    seen = set()
    while (message := host.recv(0.2)) is not None:  # type: ignore[attr-defined]
        seen.add((message.arbitration_id, bytes(message.data[:1])))
    assert (0x195, b"\x08") in seen  # key 4 pressed, once started
    assert (0x18C, b"\x08") in seen  # output 4 FAULT
    for name in ("host", "device_bus"):
        namespace[name].shutdown()  # type: ignore[attr-defined]
