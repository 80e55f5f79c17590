"""What demo, monitor and emulate print (issue 20 items 12, 13): every model's picture fits 80
columns with no key cell broken; off a terminal, plain lines, one event a line, never wrapped;
times are seconds since the start, or with --absolute the wall clock (ISO 8601 UTC)."""

from __future__ import annotations

import io
import os
import random
import re
import signal
import subprocess
import sys
import threading
import uuid
from datetime import datetime, timezone
from pathlib import Path
from typing import IO, Any

import can
import pytest
from click.testing import CliRunner
from rich.console import Console

from blinkcan.cli import demo, monitor, render
from blinkcan.cli.main import cli
from blinkcan.decode import Decoder
from blinkcan.decode.eventlog import EventLog
from blinkcan.decode.view import BusView
from blinkcan.devices.registry import models
from blinkcan.protocol import Frame
from blinkcan.twin.registry import build_twin

EPOCH = 1_700_000_000.0  # 2023-11-14T22:13:20Z
ANSI = re.compile(r"\x1b\[[0-9;?]*[A-Za-z]")
#: one event a line: time, id, data, meaning (decode's and monitor's lines)
EVENT_LINE = re.compile(r"^\s*\d+\.\d{3,6}\s+[0-9A-F]{3,8}\s+([0-9A-F]{2} )*[0-9A-F]{0,2}\s+\S")
#: emulate's: time, direction, id, data, meaning
EMULATE_LINE = re.compile(r"^\s*\d+\.\d{3} (->|<-) [0-9A-F]{3,8} ")


def _screen(width: int = 80) -> tuple[Console, io.StringIO]:
    stream = io.StringIO()
    return Console(file=stream, width=width, force_terminal=True, color_system=None,
                   highlight=False), stream


def _lines(stream: io.StringIO) -> list[str]:
    return [ANSI.sub("", line) for line in stream.getvalue().splitlines()]


@pytest.mark.parametrize("model", [m.name for m in models()])
def test_monitor_draws_every_model_within_80_columns(model: str) -> None:
    twin: Any = build_twin(model)  # a keypad or a Keybox: what its face has
    node = twin.node_id
    decoder = Decoder({node: twin.description})
    view, log = BusView(decoder), EventLog(15, decoder)
    face = twin.description.face
    frames = twin.power_on(0.0) + twin.receive(Frame(0, bytes([1, node])), 0.0)
    for pin in face.pin_numbers:
        frames += twin.blow_fuse(pin, 0.1)
    for key in face.key_numbers:
        frames += twin.press(key, 0.2)
    frames += twin.advance(5.0)
    for item in frames:
        event = decoder.decode(item, 1.0)
        view.update(event)
        log.add(event)
    console, stream = _screen()
    console.print(monitor.render(view, log))
    lines = _lines(stream)
    assert max(len(line) for line in lines) <= 80
    for line in lines:  # no key cell broken over two lines
        assert line.count("[") == line.count("]"), line
    drawn = "\n".join(lines)
    for key in face.key_numbers:
        assert re.search(rf"\[{key:>2} [^\]]*\]", drawn), key
    for pin in face.pin_numbers:
        assert re.search(rf"(^|[│ ]){pin}:OFF", drawn, re.MULTILINE), pin


@pytest.mark.parametrize("model", [m.name for m in models()])
def test_the_widest_cells_of_every_face_fit_80_columns(model: str) -> None:
    face = build_twin(model).description.face
    console, stream = _screen()
    # the longest labels a key can have (alternating, blinking yellow/green) and a pin's
    console.print(render.keypad_panel(
        ((key, "yellow/green", "off" if key % 2 else "magenta", True)
         for key in face.key_numbers), "keypad 15h, operational (~ blinking, a/b alternating)",
        face.grid))
    console.print(render.keybox_panel(((pin, "fault", True, None) for pin in face.pin_numbers),
                                      "keybox 0Ch, operational"))
    lines = _lines(stream)
    assert max(len(line) for line in lines) <= 80
    for line in lines:
        assert line.count("[") == line.count("]"), line
    drawn = "\n".join(lines)
    for pin in face.pin_numbers:
        assert f"{pin}:FAULT(fuse blown)" in drawn


def test_the_demo_fits_80_columns_on_a_terminal() -> None:
    console, stream = _screen()
    demo.run_demo(console, pause=0)
    lines = _lines(stream)
    assert max(len(line) for line in lines) <= 80
    assert any(re.search(r"\[ 1 [^]]*\] .*\[ 6 [^]]*\]", line) for line in lines)  # a row
    assert any("keybox 0Ch: outputs in FAULT: 4" in line for line in lines)


def _run(*args: str, timeout: float = 60) -> str:
    done = subprocess.run([sys.executable, "-m", "blinkcan", *args], capture_output=True,
                          text=True, timeout=timeout, check=True)
    return done.stdout


def test_the_demo_in_a_pipe_narrates_in_plain_lines() -> None:
    out = _run("demo", "--pause", "0")
    assert "\x1b" not in out
    lines = out.splitlines()
    titles = [line.removeprefix("== ") for line in lines if line.startswith("== ")]
    assert titles[1:] == [step.title for step in demo.SCRIPT]
    frames = [line for line in lines if EVENT_LINE.match(line)]
    assert any(line.endswith("keypad 15h: key 1 pressed") for line in frames)
    assert any(line.endswith("keybox 0Ch: outputs in FAULT: 4") for line in frames)
    assert any("keys lit: " in line and "outputs HIGH: [4, 7]" in line for line in lines)
    for line in lines:  # every line is whole: a frame, a narration, a state or the summary
        assert (EVENT_LINE.match(line) or line.startswith(("== ", "  keys lit: ", "Controller: "))
                or "frames on the bus" in line or not line), line


def _candump(tmp_path: Path, lines: list[tuple[float, str]]) -> Path:
    path = tmp_path / "bus.log"
    path.write_text("".join(f"({EPOCH + t:.6f}) can0 {text}\n" for t, text in lines))
    return path


def test_monitor_in_a_pipe_writes_one_line_per_event(tmp_path: Path) -> None:
    lines = [(0.0, "715#00"), (0.5, "000#0100"), (1.0, "195#0800000000")]
    lines += [(1.0 + 0.01 * n, "715#05") for n in range(1, 6)]
    lines += [(2.0, "595#8017100030000906")]  # a long meaning, not wrapped at 80
    out = _run("monitor", "--file", str(_candump(tmp_path, lines)), "--speed", "0")
    shown = out.splitlines()
    assert len(shown) == len(lines)  # one event a line, heartbeats too: a log folds nothing
    assert all(EVENT_LINE.match(line) for line in shown), shown
    assert [shown[0].split()[0], shown[-1].split()[0]] == ["0.000", "2.000"]
    assert shown[-1].endswith("06090030h invalid value for parameter")
    assert len(shown[-1]) > 80


def test_monitor_and_decode_absolute_times_are_iso_utc(tmp_path: Path) -> None:
    path = _candump(tmp_path, [(0.0, "715#00"), (1.25, "195#0800000000")])
    for command in (["monitor", "--file", str(path), "--speed", "0"], ["decode", str(path)]):
        out = CliRunner().invoke(cli, [*command, "--absolute"]).stdout
        assert "2023-11-14T22:13:20.000" in out, command
        assert "2023-11-14T22:13:21.250" in out, command
        relative = CliRunner().invoke(cli, command).stdout.splitlines()
        assert [line.split()[0] for line in relative if "keypad" in line] == \
            ["0.000", "1.250"] if command[0] == "monitor" else ["0.000000", "1.250000"]


def test_decode_json_keeps_the_logs_own_timestamps(tmp_path: Path) -> None:
    path = _candump(tmp_path, [(0.0, "715#00"), (1.25, "195#0800000000")])
    result = CliRunner().invoke(cli, ["decode", "--json", str(path)])
    assert [line.split(",")[0] for line in result.stdout.splitlines()] == \
        [f'{{"time":{EPOCH}', f'{{"time":{EPOCH + 1.25}']
    refused = CliRunner().invoke(cli, ["decode", "--json", "--absolute", str(path)])
    assert refused.exit_code == 2
    assert "--json and --parquet keep the log's own timestamps" in refused.output


def _lines_until_booted(child: subprocess.Popen[str], devices: int) -> tuple[list[str], str]:
    """The emulator's output lines: read until every device has booted (however slow the
    machine), then Ctrl-C and the lines to its end; and its standard error."""
    lines: list[str] = []
    booted = threading.Event()

    def read(stream: IO[str]) -> None:
        for line in stream:
            lines.append(line.rstrip("\n"))
            if sum(text.endswith(": boot-up") for text in lines) == devices:
                booted.set()

    assert child.stdout is not None
    reader = threading.Thread(target=read, args=(child.stdout,), daemon=True)
    reader.start()
    try:
        booted.wait(60.0)
        child.send_signal(signal.SIGINT)
        child.wait(timeout=30)
        reader.join(timeout=10)
        return lines, child.stderr.read() if child.stderr else ""
    finally:
        child.kill()


def test_emulate_in_a_pipe_writes_whole_lines_from_its_start() -> None:
    devices = [f"{m.name}:0x{0x10 + n:02X}" for n, m in enumerate(models())]
    for absolute in ((), ("--absolute",)):
        child = subprocess.Popen(
            [sys.executable, "-m", "blinkcan", "emulate", *devices, *absolute,
             "-i", "virtual", "-c", f"emulate-lines-{uuid.uuid4().hex}"],
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        lines, errors = _lines_until_booted(child, len(devices))
        assert child.returncode in (0, 130), errors
        banner, *frames = [line for line in lines if line != "stopped"]
        assert banner.endswith("Ctrl-C stops.")  # one line, never wrapped
        for model in models():
            assert model.description().title in banner
        boot_ups = [line for line in frames if line.endswith(": boot-up")]
        assert len(boot_ups) == len(devices)
        if absolute:
            today = datetime.now(timezone.utc).strftime("%Y-%m-%d")
            assert all(re.match(rf"{today}T\d\d:\d\d:\d\d\.\d{{3}}Z -> ", line)
                       for line in frames), frames
        else:
            assert all(EMULATE_LINE.match(line) for line in frames), frames
            assert all(float(line.split()[0]) < 10 for line in boot_ups)  # not the uptime


@pytest.mark.parametrize("command", [["monitor", "--speed", "0", "--file"], ["decode"]])
def test_a_reader_that_closes_the_pipe_ends_the_command_quietly(tmp_path: Path,
                                                                command: list[str]) -> None:
    """``blinkcan monitor --file LOG | head -2`` exited 1, silently (rich's answer to a broken
    pipe), where ``decode`` exits 0: a reader closing stdout is the reader's choice, not an
    error. Both now stop at once, exit 0, no traceback."""
    path = _candump(tmp_path, [(0.01 * n, "715#05") for n in range(20000)])  # > a pipe's buffer
    child = subprocess.Popen([sys.executable, "-m", "blinkcan", *command, str(path)],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        _reads_two_lines_and_closes(child)
    finally:
        child.kill()


def _reads_two_lines_and_closes(child: subprocess.Popen[str]) -> None:
    """As ``| head -2``: two event lines read, stdout closed; the command then exits 0 with
    only its one line of assumed devices on stderr."""
    assert child.stdout is not None
    assert child.stderr is not None
    head = [child.stdout.readline() for _ in range(2)]
    child.stdout.close()
    assert child.wait(timeout=60) == 0
    errors = child.stderr.read()
    assert all(EVENT_LINE.match(line) for line in head), head
    assert errors.startswith("no --device given: assuming"), errors
    assert errors.count("\n") == 1, errors


def test_a_reader_that_closes_the_pipe_ends_the_live_monitor_quietly() -> None:
    """The live monitor too: ``blinkcan monitor | head -2`` on a bus that keeps sending."""
    channel = f"239.74.{random.randint(1, 254)}.{random.randint(1, 254)}"
    port = random.randint(40000, 60000)
    environment = {k: v for k, v in os.environ.items() if not k.startswith("CAN_")}
    child = subprocess.Popen(
        [sys.executable, "-m", "blinkcan", "monitor", "-i", "udp_multicast", "-c", channel,
         "--bus-kwargs", f"port={port}", "hop_limit=0"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=environment)
    stop = threading.Event()

    def send() -> None:  # a heartbeat every 10 ms until the monitor is gone
        with can.Bus(interface="udp_multicast", channel=channel, port=port,
                     hop_limit=0) as bus:
            while not stop.wait(0.01):
                bus.send(can.Message(arbitration_id=0x715, data=b"\x05",
                                     is_extended_id=False))

    sender = threading.Thread(target=send, daemon=True)
    sender.start()
    try:
        _reads_two_lines_and_closes(child)
    finally:
        stop.set()
        child.kill()
        sender.join(timeout=10)
