"""What monitor, demo and the panel show a person: folded heartbeats, times from the start,
alternating LEDs as alternating, PWM as PWM, replay over time, the default nodes said."""

from __future__ import annotations

import io
import re
import time
import uuid
from pathlib import Path
from types import SimpleNamespace

import can
import pytest
from click.testing import CliRunner
from rich.console import Console

from blinkcan.cli import demo, monitor
from blinkcan.cli.main import cli
from blinkcan.cli.render import key_cell
from blinkcan.decode import Decoder
from blinkcan.decode.eventlog import EventLog
from blinkcan.runtime import Emulator, to_message
from blinkcan.twin import KeyboxTwin, KeypadTwin
from tests.conftest import frame

EPOCH = 1_700_000_000.0


def _log(tmp_path: Path, lines: list[tuple[float, str]]) -> Path:
    path = tmp_path / "bus.log"
    path.write_text("".join(f"({EPOCH + t:.6f}) can0 {text}\n" for t, text in lines))
    return path


def _monitor(*args: str) -> tuple[str, str]:
    # the picture, as a terminal shows it (rich: TTY_COMPATIBLE); a pipe gets lines
    result = CliRunner().invoke(cli, ["monitor", "--speed", "0", *args],
                                env={"COLUMNS": "160", "TTY_COMPATIBLE": "1", "NO_COLOR": "1"})
    assert result.exit_code == 0, result.output
    return result.stdout, result.stderr


def test_repeated_heartbeats_fold_into_one_row_per_node(tmp_path: Path) -> None:
    lines = [(0.0, "000#0100"), (0.001, "195#0800000000")]
    lines += [(0.01 * n, "715#05") for n in range(1, 31)]
    lines += [(0.01 * n + 0.005, "70C#05") for n in range(1, 31)]
    out, _ = _monitor("--file", str(_log(tmp_path, lines)), "--rows", "5")
    assert "keypad 15h: key 4 pressed" in out  # not pushed off by 60 heartbeats
    assert "keypad 15h: heartbeat, operational (x30)" in out
    assert "keybox 0Ch: heartbeat, operational (x30)" in out


def test_times_are_shown_from_the_first_event(tmp_path: Path) -> None:
    out, _ = _monitor("--file", str(_log(tmp_path, [(0.0, "715#00"), (1.25, "195#08000000")])))
    assert re.search(r"0\.000 .*715", out)
    assert re.search(r"1\.250 .*195", out)
    assert "1700000000" not in out


def test_an_alternating_led_is_drawn_alternating_not_as_a_mixed_blink(tmp_path: Path) -> None:
    # key 1: red on, red + green blinking -> red and green alternate (errata P9)
    lines = [(0.0, "215#0100000000000000"), (0.01, "315#0110000000000000")]
    out, _ = _monitor("--file", str(_log(tmp_path, lines)))
    assert "[ 1 red/gre" in out
    assert "~yellow" not in out
    assert key_cell(2, "off", "green").plain == "[ 2 ~green ]"
    assert key_cell(3, "blue", "blue").plain == "[ 3 blue   ]"


def test_pwm_pins_are_shown_as_pwm_with_their_duty(tmp_path: Path) -> None:
    lines = [(0.0, "60C#2B09200102050000"), (0.001, "58C#6009200100000000")]
    out, _ = _monitor("--file", str(_log(tmp_path, lines)))
    assert "13:PWM 50%" in out
    assert "12:OFF" in out


def test_without_device_the_default_nodes_are_assumed_and_said(tmp_path: Path) -> None:
    out, err = _monitor("--file", str(_log(tmp_path, [(0.0, "18C#0800000000000000")])))
    assert "assuming keybox 0Ch, keypad 15h" in err
    assert "keybox 0Ch: outputs in FAULT: 4" in out


class _Clock:
    """time.monotonic and time.sleep for the replay, without waiting."""

    def __init__(self) -> None:
        self.now = 100.0
        self.slept: list[float] = []

    def monotonic(self) -> float:
        return self.now

    def sleep(self, seconds: float) -> None:
        self.slept.append(seconds)
        self.now += seconds


@pytest.mark.parametrize(("speed", "slept"), [("1", 3.0), ("2", 1.5), ("0", 0.0)])
def test_a_file_is_replayed_at_its_own_pace(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                            speed: str, slept: float) -> None:
    clock = _Clock()
    monkeypatch.setattr(monitor, "time", SimpleNamespace(monotonic=clock.monotonic,
                                                         sleep=clock.sleep))
    path = _log(tmp_path, [(0.0, "715#05"), (1.0, "215#0100000000000000"), (3.0, "715#05")])
    result = CliRunner().invoke(cli, ["monitor", "--file", str(path), "--speed", speed])
    assert result.exit_code == 0, result.output
    assert sum(clock.slept) == pytest.approx(slept)
    assert "LEDs on: red 1" in result.stdout  # off a terminal: a line per event


def test_the_event_log_folds_and_counts() -> None:
    decoder, log = Decoder({0x15: "keypad"}), EventLog(3)
    for n in range(5):
        log.add(decoder.decode(frame("715 05"), 10.0 + n))
    log.add(decoder.decode(frame("715 7F"), 20.0))  # another state: a row of its own
    texts = [row.text() for row in log.rows]
    assert texts == ["keypad 15h: heartbeat, operational (x5)",
                     "keypad 15h: heartbeat, pre-operational"]
    assert log.since_start(log.rows[-1].event) == 10.0
    with pytest.raises(ValueError, match="rows must be 1 or more"):
        EventLog(0)


def test_the_panel_folds_heartbeats_and_shows_times_from_the_start() -> None:
    pytest.importorskip("starlette", reason="the web extra is not installed")
    from blinkcan.web.app import Panel

    channel = f"panel-log-{uuid.uuid4().hex}"
    device_bus, host = (can.Bus(interface="virtual", channel=channel) for _ in range(2))
    try:
        with Emulator(device_bus, [KeypadTwin(), KeyboxTwin()]) as emulator:
            panel = Panel(emulator)
            for _ in range(25):
                host.send(to_message(frame("77F 05")))  # the controller's heartbeat
            # python-can's reader thread hands the frames over: under load it may wait its
            # turn for a while (200 quick round trips to the emulator's loop were not always
            # enough), so the bound is wall time, generous; the test only waits for the fold
            deadline = time.monotonic() + 30
            while (not any("(x25)" in f["text"] for f in panel.frames)
                   and time.monotonic() < deadline):
                emulator.run(lambda now: None)  # let the emulator's thread take the frames
                time.sleep(0.005)
            frames = panel.frames
    finally:
        device_bus.shutdown()
        host.shutdown()
    folded = [f for f in frames if f["id"] == "77F"]
    assert len(folded) == 1
    assert folded[0]["text"].endswith("(x25)")
    assert all(float(f["time"]) < 1000 for f in frames)  # seconds from the start, not epoch


def test_demo_web_says_the_script_result_then_waits_then_the_end() -> None:
    pytest.importorskip("starlette", reason="the web extra is not installed")
    stream = io.StringIO()
    console = Console(file=stream, width=160, highlight=False)
    seen_while_waiting: list[str] = []
    demo.run_demo(console, pause=0, web="127.0.0.1:0",
                  wait=lambda: seen_while_waiting.append(stream.getvalue()))
    before, after = seen_while_waiting[0], stream.getvalue()
    assert "after the script: outputs HIGH [4, 7]" in before
    assert before.rstrip().endswith("the controller keeps running with the panel; Ctrl-C stops")
    assert "at the end" not in before  # the end is said at the end
    assert "outputs HIGH at the end: [4, 7]" in after[len(before):]
    assert "\nthe controller keeps running" in before  # on a line of its own
