"""Typed commands on ``blinkcan emulate``'s input act on its devices (issue 20 item 11): every
action a registered model's face has, for every model, generation, quirk profile and protocol
(tests/conformance/cases.py), does what the testing kit's Rig call does; bad commands are one
``Error:`` line naming what is valid; the reader answers from a pipe and outlives its end."""

from __future__ import annotations

import io
import os
import queue
import random
import select
import shlex
import shutil
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import can
import pytest
from rich.console import Console

from blinkcan.cli.emulate import build_twins
from blinkcan.cli.typed_commands import MAX_LINE, TIMED, TypedCommands, typed_commands, word
from blinkcan.runtime import Emulator
from blinkcan.testing import Rig
from blinkcan.twin.actions import ACTIONS, Action, actions_of
from blinkcan.twin.base import CanopenTwin
from blinkcan.twin.registry import build_twin
from tests.conformance.cases import Case, cases
from tests.processes import stop

#: what the testing kit does for each action: the reference a typed command must match
RIG_CALLS: dict[str, Callable[[Rig, CanopenTwin, dict[str, Any]], None]] = {
    "press": lambda rig, t, a: rig.press(t, a["key"]),
    "release": lambda rig, t, a: rig.release(t, a["key"]),
    "turn": lambda rig, t, a: rig.turn(t, a["encoder"], a["ticks"]),
    "set_analog": lambda rig, t, a: rig.set_analog(t, a["input"], a["volts"]),
    "set_digital_input": lambda rig, t, a: rig.set_digital_input(t, a["input"],
                                                                 bool(a["level"])),
    "blow_fuse": lambda rig, t, a: rig.blow_fuse(t, a["pin"]),
    "replace_fuse": lambda rig, t, a: rig.replace_fuse(t, a["pin"]),
    "input_high": lambda rig, t, a: rig.set_input(t, a["pin"], True),
    "input_low": lambda rig, t, a: rig.set_input(t, a["pin"], False),
    "power_off": lambda rig, t, a: rig.power_off(t),
    "power_on": lambda rig, t, a: rig.power_on(t),
}
TIMED_RIG_CALLS: dict[str, Callable[[Rig, CanopenTwin, dict[str, Any]], None]] = {
    "tap": lambda rig, t, a: rig.tap(t, a["key"], 0.1),
    "power-cycle": lambda rig, t, a: rig.power_cycle(t, 0.1),
}


def test_every_action_has_a_rig_reference() -> None:
    assert set(RIG_CALLS) == set(ACTIONS)
    assert set(TIMED_RIG_CALLS) == set(TIMED)


def _twin(case: Case) -> CanopenTwin:
    options: dict[str, Any] = {} if case.canopen else {"protocol": case.protocol}
    return build_twin(case.spec, quirks=case.quirks, **options)


@pytest.fixture
def two_rigs() -> Iterator[tuple[Rig, Rig]]:
    typed, reference = Rig(), Rig()
    yield typed, reference
    typed.close()
    reference.close()


def _values(action: Action, case_twin: CanopenTwin) -> dict[str, Any]:
    """The highest value of every argument on the twin's face (the edge of each range)."""
    face = case_twin.description.face
    return {argument.name: argument.bounds(face)[1] for argument in action.arguments}


def _typed(word_: str, values: dict[str, Any]) -> str:
    return " ".join([word_, *(str(value) for value in values.values())])


def _frames(rig: Rig) -> list[tuple[float, int, bytes]]:
    return [(round(t.time, 9), t.frame.can_id, t.frame.data) for t in rig.frames]


@pytest.mark.parametrize("case", cases("typed commands"))
def test_every_action_of_the_face_typed_does_what_the_rig_does(
        case: Case, two_rigs: tuple[Rig, Rig]) -> None:
    typed_rig, reference_rig = two_rigs
    typed_twin, reference_twin = typed_rig.add(_twin(case)), reference_rig.add(_twin(case))
    commands = TypedCommands(typed_rig.emulator)
    for rig in two_rigs:
        rig.advance(10.0)  # past any start-up show
        rig.bus.send(can.Message(arbitration_id=0, data=[1, 0], is_extended_id=False))
        rig.settle()
    changed = 0
    face = typed_twin.description.face
    steps: list[tuple[str, dict[str, Any], Callable[..., None]]] = [
        (word(action.name), _values(action, typed_twin), RIG_CALLS[action.name])
        for action in actions_of(face)]
    steps += [(timed.word, _values(ACTIONS[timed.first], typed_twin),
               TIMED_RIG_CALLS[timed.word])
              for timed in TIMED.values() if ACTIONS[timed.first].fits(face)]
    assert {"power-off", "power-on", "power-cycle"} <= {step[0] for step in steps}
    for typed, values, reference in steps:
        before = typed_rig.snapshot(typed_twin)
        answer = commands.execute(_typed(typed, values))
        reference(reference_rig, reference_twin, values)
        for rig in two_rigs:
            rig.settle()
        assert len(answer) == 1, answer
        assert answer[0].startswith(f"{typed_twin.description.title} "), answer
        assert typed_rig.snapshot(typed_twin) == reference_rig.snapshot(reference_twin), typed
        assert _frames(typed_rig) == _frames(reference_rig), typed
        changed += typed_rig.snapshot(typed_twin) != before
    assert changed >= len(steps) // 2  # the actions did something: pressed, blown, off...


@pytest.mark.parametrize("case", cases("typed commands"))
def test_help_lists_what_the_face_has_and_the_rest_is_refused(case: Case) -> None:
    with Rig() as rig:
        twin = rig.add(_twin(case))
        face = twin.description.face
        commands = TypedCommands(rig.emulator)
        text = "\n".join(commands.execute("help"))
        has = actions_of(face)
        for action in has:
            assert f"  {word(action.name)}" in text
            for argument in action.arguments:
                assert argument.describe(face) in text
        for action in ACTIONS.values():
            if action not in has:
                assert f"  {word(action.name)}" not in text
                answer = commands.execute(_typed(word(action.name), {"x": 1}))
                assert len(answer) == 1, answer
                assert answer[0].startswith("Error: "), answer
                assert all(word(a.name) in answer[0] for a in has), answer
        [listed] = commands.execute("list")
        assert listed.startswith(twin.description.title)
        assert listed.endswith("pre-operational" if case.canopen else "(address claim: off)")


@pytest.fixture
def three_devices() -> Iterator[tuple[Rig, TypedCommands, list[CanopenTwin]]]:
    with Rig() as rig:
        twins = [rig.add(t) for t in build_twins(
            ("keypad", "keybox", "pkp-3500-mt:0x16"), None, None, "firmware")]
        yield rig, TypedCommands(rig.emulator), twins


@pytest.mark.parametrize(("line", "names"), [
    ("pres 3", ["press", "blow-fuse", "Keybox 0Ch"]),              # unknown: commands, devices
    ("press 3", ["15h", "16h"]),                                     # which device?
    ("15h press 13", ["key must be 1..12"]),                         # the model's own range
    ("16h press x", ["key must be 1..15"]),
    ("15h press", ["usage: press KEY (key 1..12)"]),
    ("15h press 1 2", ["usage: press KEY"]),
    ("turn 3 5", ["encoder must be 1..2"]),
    ("turn 1 65", ["ticks must be -64..64"]),
    ("set-analog 0 nan", ["volts must be 0.0..5.0"]),
    ("set-analog 0 -1", ["volts must be 0.0..5.0"]),
    ("0Ch press 3", ["has no 'press'", "blow-fuse", "power-cycle"]),
    ("15h turn 1 1", ["has no 'turn'", "press, release"]),
    ("99h press 3", ["unknown command or device '99h'", "Keybox 0Ch"]),
    ("power-cycle 0C", ["the device goes first: 0C power-cycle"]),
    ("15h tap 3 -1", ["SECONDS must be a number >= 0"]),
    ("15h tap 3 inf", ["SECONDS must be a number >= 0"]),
    ("15h tap 3 1e308", ["SECONDS must be", "0..31622400"]),      # no timer reaches it
    ("keybox power-cycle 1e300", ["SECONDS must be", "0..31622400"]),  # not left off
    ("wait 1e300", ["SECONDS must be", "0..31622400"]),
    ("wait", ["usage: wait SECONDS"]),
    ("16h", ["what should", "turn"]),
    ("help 77h", ["unknown command or device '77h'"]),
])
def test_a_bad_command_is_one_line_naming_what_is_valid(
        three_devices: tuple[Rig, TypedCommands, list[CanopenTwin]], line: str,
        names: list[str]) -> None:
    rig, commands, twins = three_devices
    before = [rig.snapshot(t) for t in twins]
    answer = commands.execute(line)
    assert len(answer) == 1, answer
    assert answer[0].startswith("Error: "), answer
    for name in names:
        assert name in answer[0]
    assert [rig.snapshot(t) for t in twins] == before  # nothing done
    assert commands.execute("15h press 3") == ["PKP-2600-SI keypad 15h: press key 3"]


def test_a_device_is_named_by_address_as_shown_or_by_model(
        three_devices: tuple[Rig, TypedCommands, list[CanopenTwin]]) -> None:
    rig, commands, (keypad, keybox, _) = three_devices
    for device, key in (("15h", 1), ("0x15", 2), ("15", 3), ("21", 4), ("keypad", 5),
                        ("pkp-2600-si", 6)):
        assert commands.execute(f"{device} press {key}") == [
            f"PKP-2600-SI keypad 15h: press key {key}"]
    assert [k["pressed"] for k in rig.snapshot(keypad)["keys"][:6]] == [True] * 6
    assert commands.execute("0C blow-fuse 4") == ["Keybox 0Ch: blow-fuse pin 4"]  # unique
    assert rig.snapshot(keybox)["pins"][3]["fuse"] == "blown"
    assert commands.execute("turn 2 -3") == ["PKP-3500-MT keypad 16h: turn encoder 2, ticks -3"]
    assert commands.execute("# a comment") == []
    assert commands.execute("   ") == []


def test_a_j1939_keypad_is_named_by_its_source_address_or_node_id() -> None:
    with Rig() as rig:
        keypad = rig.add(build_twin("keypad", protocol="j1939"))
        rig.add(build_twin("keybox"))
        commands = TypedCommands(rig.emulator)
        for device, key in (("21h", 1), ("21", 2), ("15h", 3)):
            assert commands.execute(f"{device} press {key}") == [
                f"PKP-2600-SI keypad 21h (J1939): press key {key}"]
        rig.settle()
        assert [k["pressed"] for k in rig.snapshot(keypad)["keys"][:3]] == [True] * 3


def test_tap_and_wait_take_the_time_they_name(
        three_devices: tuple[Rig, TypedCommands, list[CanopenTwin]]) -> None:
    rig, commands, (keypad, *_) = three_devices
    start = rig.now
    assert commands.execute("15h tap 4 2.5") == ["PKP-2600-SI keypad 15h: tap key 4"]
    assert rig.now == pytest.approx(start + 2.5)
    assert not rig.snapshot(keypad)["keys"][3]["pressed"]
    commands.execute("wait 1")
    assert rig.now == pytest.approx(start + 3.5)


# -- reading the input --------------------------------------------------------------------------

@pytest.fixture
def live_emulator() -> Iterator[Emulator]:
    channel = f"typed-{random.getrandbits(48):x}"
    bus = can.Bus(interface="virtual", channel=channel)
    twins = build_twins(("keypad", "keybox"), None, None, "firmware")
    with Emulator(bus, twins) as emulator:
        yield emulator
    bus.shutdown()


def _wait_for(condition: Callable[[], bool], timeout: float = 20.0) -> None:
    deadline = time.monotonic() + timeout
    while not condition():
        assert time.monotonic() < deadline, "not within the time allowed"
        time.sleep(0.01)


def test_commands_from_a_pipe_are_carried_out_and_its_end_stops_only_the_reading(
        live_emulator: Emulator) -> None:
    output = io.StringIO()
    console = Console(file=output, width=80)
    read_end, write_end = os.pipe()
    with os.fdopen(read_end) as stdin, \
            typed_commands(live_emulator, console, stdin=stdin):
        os.write(write_end, b"15h press 3\nbogus\n" + b"x" * (MAX_LINE + 10))
        os.write(write_end, b"x" * 10 + b"\n0Ch blow-fuse 4\nkeybox blow-fuse 5")  # no newline
        os.close(write_end)  # the end of the input: the last line still counts
        _wait_for(lambda: "blow-fuse pin 5" in output.getvalue())
        readers = [t for t in threading.enumerate() if t.name == "blinkcan-commands"]
        for reader in readers:
            reader.join(timeout=20)
        assert not any(reader.is_alive() for reader in readers)
        keypad, keybox = live_emulator.twins
        assert live_emulator.snapshot(keypad)["keys"][2]["pressed"]  # still emulating
        assert [p["fuse"] for p in live_emulator.snapshot(keybox)["pins"][3:5]] == ["blown"] * 2
    lines = output.getvalue().splitlines()
    assert lines[0] == "PKP-2600-SI keypad 15h: press key 3"
    assert lines[1].startswith("Error: unknown command or device 'bogus'; commands: help")
    assert lines[2] == f"Error: a command longer than {MAX_LINE} characters was dropped"
    assert lines[3:] == ["Keybox 0Ch: blow-fuse pin 4", "Keybox 0Ch: blow-fuse pin 5"]


def test_commands_from_a_stream_without_a_descriptor(live_emulator: Emulator) -> None:
    output = io.StringIO()
    with typed_commands(live_emulator, Console(file=output), stdin=io.StringIO("15h press 7\n")):
        _wait_for(lambda: "press key 7" in output.getvalue())


# -- the command line ---------------------------------------------------------------------------

@pytest.mark.multiprocess
def test_emulate_reads_commands_on_its_input_and_emulates_on_after_its_end() -> None:
    channel = f"239.74.{random.randint(1, 254)}.{random.randint(1, 254)}"
    port = random.randint(40000, 60000)
    try:
        host = can.Bus(interface="udp_multicast", channel=channel, port=port, hop_limit=0,
                       receive_own_messages=False)
    except (OSError, ImportError, can.CanError) as error:
        pytest.skip(f"udp_multicast unavailable here ({error})")
    environment = {**{k: v for k, v in os.environ.items() if not k.startswith("CAN_")},
                   "PYTHONUNBUFFERED": "1"}
    child = subprocess.Popen(
        [sys.executable, "-m", "blinkcan", "emulate", "keypad", "keybox", "-q", "-i",
         "udp_multicast", "-c", channel, "--bus-kwargs", f"port={port}", "hop_limit=0"],
        stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
        env=environment, text=True)
    assert child.stdin is not None
    assert child.stdout is not None
    try:
        child.stdin.write("0Ch blow-fuse 4\nfuse 4\n")
        child.stdin.close()  # the end of the input: emulating goes on
        lines: queue.SimpleQueue[str] = queue.SimpleQueue()
        stdout = child.stdout

        def read_lines() -> None:
            for line in stdout:
                lines.put(line)

        threading.Thread(target=read_lines, daemon=True).start()
        seen = [lines.get(timeout=30)]
        while "blow-fuse" not in seen[-1]:  # after the banner
            seen.append(lines.get(timeout=30))
        seen.append(lines.get(timeout=30))
        assert seen[-2:] == ["Keybox 0Ch: blow-fuse pin 4\n",
                             f"Error: unknown command or device 'fuse'; commands: help, list, "
                             f"wait, {', '.join(word(name) for name in ACTIONS)}, tap, "
                             "power-cycle; devices: PKP-2600-SI keypad 15h, Keybox 0Ch\n"], seen
        host.send(can.Message(arbitration_id=0x60C, data=bytes.fromhex("4001200400000000"),
                              is_extended_id=False))  # an SDO request: any reply proves it runs
        deadline = time.monotonic() + 20
        while time.monotonic() < deadline:
            reply = host.recv(timeout=1)
            if reply is not None and reply.arbitration_id == 0x58C:
                break
        else:
            pytest.fail("no SDO reply after the end of the commands")
        assert child.poll() is None
    finally:
        stop(child)
        host.shutdown()


# -- the README ---------------------------------------------------------------------------------

README = Path(__file__).resolve().parents[2] / "README.md"


def test_the_readme_session_runs_as_written() -> None:
    section = README.read_text().split("## Pressing keys from the terminal", 1)[1]
    typed_block = section.split("```text\n", 1)[1].split("```", 1)[0].splitlines()
    piped = section.split("```sh\n", 1)[1].split("```", 1)[0]
    started, *lines = typed_block
    devices = shlex.split(started)[3:]  # $ blinkcan emulate DEVICES
    printed = shlex.split(piped)[1].encode().decode("unicode_escape").splitlines()
    assert shlex.split(piped)[2:] == ["|", "blinkcan", "emulate", "keypad", "keybox"]
    for devices_of, script in ((devices, lines), (["keypad", "keybox"], printed)):
        with Rig() as rig:
            for twin in build_twins(tuple(devices_of), None, None, "firmware"):
                rig.add(twin)
            commands = TypedCommands(rig.emulator)
            for line in script:
                answer = commands.execute(line)
                assert answer or line.startswith("wait "), line
                assert not any(out.startswith("Error") for out in answer), (line, answer)


@pytest.mark.multiprocess
@pytest.mark.skipif(not hasattr(os, "fork") or shutil.which("bash") is None,
                    reason="needs a POSIX terminal and bash")
def test_emulate_in_the_background_of_a_terminal_keeps_running() -> None:
    """``blinkcan emulate keypad &`` in an interactive shell: reading the terminal from the
    background would stop the job (SIGTTIN); it runs on, and reads once in the foreground."""
    import pty

    group = f"239.74.{random.randint(1, 254)}.{random.randint(1, 254)}"
    shell, terminal = pty.fork()
    if shell == 0:  # the child: an interactive shell with job control on the terminal
        for stop in (signal.SIGTTIN, signal.SIGTTOU, signal.SIGTSTP):
            signal.signal(stop, signal.SIG_DFL)  # as a terminal's shell has them
        os.execvpe("bash", ["bash", "--norc", "--noprofile", "-i"],
                   {**os.environ, "PS1": "$ ", "PYTHONUNBUFFERED": "1"})
    seen = ""

    def until(*texts: str) -> str:
        """Read the terminal until one of ``texts`` comes; the text after the last command."""
        nonlocal seen
        start, deadline = len(seen), time.monotonic() + 30
        while not any(text in seen[start:] for text in texts):
            assert time.monotonic() < deadline, seen
            ready, _, _ = select.select([terminal], [], [], 0.2)
            if ready:
                seen += os.read(terminal, 65536).decode(errors="replace")
        return seen[start:]

    try:
        os.write(terminal, (f"{sys.executable} -m blinkcan emulate keypad -q -i udp_multicast "
                            f"-c {group} --bus-kwargs port={random.randint(40000, 60000)} "
                            "hop_limit=0 &\n").encode())
        until("Type commands here")
        for _ in range(4):  # its reading thread has started: a stop would show by now
            time.sleep(0.5)
            os.write(terminal, b"jobs\n")
            assert "Running" in until("Running", "Stopped"), seen
        os.write(terminal, b"fg\n15h list\n")
        until("PKP-2600-SI keypad 15h, generation 1 (manual rev 1.1): pre-operational")
        os.write(terminal, b"\x03")  # Ctrl-C
        until("stopped")
    finally:
        os.close(terminal)  # the shell and its jobs get SIGHUP
        for _ in range(100):
            if os.waitpid(shell, os.WNOHANG)[0]:
                break
            time.sleep(0.1)
        else:
            os.kill(shell, signal.SIGKILL)
            os.waitpid(shell, 0)
