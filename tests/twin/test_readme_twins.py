"""The README's twin examples run as written, send what their comments say, and leave
nothing open: a newcomer copying them sees no warning (they left their virtual buses open:
python-can's "VirtualBus was not properly shut down" when collected)."""

from __future__ import annotations

import gc
import logging
import re
import warnings
from pathlib import Path

import can
import pytest

README = Path(__file__).resolve().parents[2] / "README.md"


def test_readme_twin_examples_run_as_written(capsys: pytest.CaptureFixture[str],
                                             caplog: pytest.LogCaptureFixture) -> None:
    text = README.read_text()
    section = text[text.index("## A keypad twin in ten lines"):text.index("## Command line")]
    blocks = re.findall(r"```python\n(.*?)```", section, re.S)
    assert len(blocks) == 3
    sniffer = can.Bus(interface="virtual", channel="bench")  # hears what the examples send
    try:
        with warnings.catch_warnings(record=True) as warned, caplog.at_level(logging.WARNING):
            warnings.simplefilter("always")
            namespace: dict[str, object] = {}
            for block in blocks:
                exec(compile(block, "README.md", "exec"), namespace)
            namespace.clear()
            gc.collect()  # a bus left open says so when collected
        seen = set()
        while (message := sniffer.recv(0.2)) is not None:
            seen.add((message.arbitration_id, bytes(message.data[:1])))
    finally:
        sniffer.shutdown()
    assert "'pressed': True" in capsys.readouterr().out
    assert (0x195, b"\x08") in seen  # key 4 pressed, once started
    assert (0x18C, b"\x08") in seen  # output 4 FAULT
    assert [str(w.message) for w in warned] == []
    assert [r.getMessage() for r in caplog.records if r.levelno >= logging.WARNING] == []
