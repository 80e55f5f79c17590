"""The README's "Testing your controller" example runs as written."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from blinkcan import Keybox, Keypad
from blinkcan.testing import Rig
from blinkcan.twin import KeyboxTwin, KeypadTwin

README = Path(__file__).resolve().parents[2] / "README.md"


def test_readme_testing_example_runs(capsys: pytest.CaptureFixture[str]) -> None:
    text = README.read_text()
    section = text[text.index("## Testing your controller"):]
    code = re.search(r"```python\n(.*?)```", section, re.S)
    assert code is not None
    exec(compile(code.group(1), "README.md", "exec"), {})
    now, frames = capsys.readouterr().out.split()
    assert 1.0 < float(now) < 2.0
    assert int(frames) > 10


def test_readme_resync_pattern_rederives_the_leds_when_the_keybox_power_cycles() -> None:
    """The README's "show what the device reports" block, run as written on a rig."""
    text = README.read_text()
    section = text[text.index("The pattern it teaches"):]
    code = re.search(r"```python\n(.*?)```", section, re.S)
    assert code is not None
    with Rig() as rig:
        keypad_twin = rig.add(KeypadTwin(settings={"startup_led_show": 0}))
        keybox_twin = rig.add(KeyboxTwin())
        keypad, keybox = Keypad(rig.bus, 0x15), Keybox(rig.bus, 0x0C)
        exec(compile(code.group(1), "README.md", "exec"), {"keypad": keypad, "keybox": keybox})
        keybox.on(4)
        keypad.set_led(4, "green")
        rig.power_cycle(keybox_twin)
        rig.advance(0.5)
        assert keybox_twin.snapshot()["pins"][3]["state"] == "off"
        assert keypad_twin.snapshot()["commanded"][3]["colour"] == "off"
        keypad.close()
        keybox.close()
