"""The README's python-canopen and cantools examples ("Controllers on python-canopen, cantools
or python-can") run as written, in virtual time."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

README = Path(__file__).resolve().parents[2] / "README.md"


def _blocks() -> list[str]:
    text = README.read_text()
    section = text[text.index("### Controllers on python-canopen"):]
    section = section[:section.index("\n## ")]
    return re.findall(r"```python\n(.*?)```", section, re.S)


def test_the_python_canopen_example_runs(capsys: pytest.CaptureFixture[str]) -> None:
    exec(compile(_blocks()[0], "README.md", "exec"), {})
    faults, lost = capsys.readouterr().out.splitlines()
    assert faults.startswith("faults 08")  # output 4: bit 3 of the first byte
    assert lost == "heartbeat lost at 0.5"


def test_the_cantools_example_runs(capsys: pytest.CaptureFixture[str]) -> None:
    exec(compile(_blocks()[1], "README.md", "exec"), {})
    heartbeat, faults = capsys.readouterr().out.splitlines()
    assert heartbeat == "{'state': 'operational'}"
    assert "'faults_4': 1" in faults
    assert faults.endswith(" 0.1")  # the first heartbeat came at 0.1 virtual s
