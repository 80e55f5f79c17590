"""``blinkcan demo``: a small controller on twins, shown live.

A keypad (15h) and a Keybox (0Ch) twin run in an Emulator on a virtual bus; the controller uses
the host drivers only, as an application would: key N toggles output N, and the key's LED shows
the output (green on, off when off, red blinking on FAULT). A script presses keys, blows a fuse
and power-cycles the keypad; the live view shows the keypad, the outputs and the frames
(heartbeats and unchanged periodic frames folded). Off a terminal (a pipe, a file) it writes
plain lines instead: each step's narration, each frame that is news (seconds since the start),
and after each step what the devices show.
"""

from __future__ import annotations

import functools
import queue
import threading
import time
import uuid
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import can
import click
from rich.console import Console, Group
from rich.live import Live
from rich.panel import Panel
from rich.text import Text

from blinkcan.cli.clock import Clock
from blinkcan.cli.demo_model import run_model_demo, until_interrupted
from blinkcan.cli.emulate import panel, panel_address
from blinkcan.cli.render import keybox_panel, keypad_panel, output_console
from blinkcan.cli.seconds import Seconds
from blinkcan.decode import Decoder
from blinkcan.decode.eventlog import EventLog, Row
from blinkcan.devices.model import Model
from blinkcan.devices.registry import model_names, models, parse_spec
from blinkcan.host import HostBus, Keybox, Keypad, Toggle
from blinkcan.host.keybox import FaultEvent
from blinkcan.protocol.frame import Frame
from blinkcan.runtime import Emulator
from blinkcan.twin import KeyboxTwin, KeypadTwin


class Controller:
    """Key N toggles output N; faults show as a red blinking LED. SDO work runs on a worker
    thread, because driver callbacks run on the bus thread."""

    def __init__(self, keypad: Keypad, keybox: Keybox) -> None:
        self.keypad, self.keybox = keypad, keybox
        self._work: queue.SimpleQueue[tuple[str, int, int] | threading.Event] = queue.SimpleQueue()
        self.toggles = {
            key: Toggle(keypad, key, on="green", on_change=functools.partial(self._pressed, key))
            for key in keypad.description.face.led_keys
            if key in keybox.description.face.pin_numbers  # key N toggles output N
        }
        keybox.on_fault(self._on_fault)
        self._worker = threading.Thread(target=self._run, name="demo-controller", daemon=True)
        self._worker.start()

    def _pressed(self, key: int, state: int) -> None:
        self._work.put(("key", key, state))

    def _on_fault(self, event: FaultEvent) -> None:
        if event.fault and event.pin in self.toggles:
            self._work.put(("fault", event.pin, 1))

    def _run(self) -> None:
        while True:
            item = self._work.get()
            if isinstance(item, threading.Event):  # idle(): all earlier work is done
                item.set()
                continue
            kind, key, state = item
            if kind == "stop":
                return
            if kind == "fault":
                self.toggles[key].set_state(0)
                self.keypad.set_led(key, "off", blink="red")
            elif key in self.keybox.fault_pins:
                self.keybox.reset(key)  # a press on a faulted output resets it (OFF)
                self.toggles[key].set_state(0)
            elif state:
                self.keybox.on(key)
            else:
                self.keybox.off(key)

    def settle(self, timeout: float = 5.0) -> None:
        """Wait until the controller has taken every frame the devices sent so far and done
        what they asked: the Keybox answers the controller's look at its outputs (SDO) after
        those frames (one emulator, one bus: in order), then the worker's queue is waited
        out. A fixed sleep was too short for a loaded host."""
        self.keybox.states()
        self.idle(timeout)

    def idle(self, timeout: float = 5.0) -> None:
        """Wait until the worker has done what was asked so far."""
        done = threading.Event()
        self._work.put(done)
        done.wait(timeout)

    def stop(self) -> None:
        self._work.put(("stop", 0, 0))
        self._worker.join(timeout=2)


@dataclass(frozen=True)
class Step:
    title: str
    act: Callable[[Emulator, KeypadTwin, KeyboxTwin], object]


def _press(key: int) -> Callable[[Emulator, KeypadTwin, KeyboxTwin], object]:
    def act(emulator: Emulator, keypad: KeypadTwin, keybox: KeyboxTwin) -> None:
        emulator.press(keypad, key)
        emulator.release(keypad, key)

    return act


SCRIPT = (
    Step("Press key 1: output 1 on", _press(1)),
    Step("Press key 4: output 4 on", _press(4)),
    Step("Press key 7: output 7 on", _press(7)),
    Step("The fuse of output 4 blows: FAULT, key 4 blinks red",
         lambda emu, kp, kb: emu.run(lambda now: kb.blow_fuse(4, now))),
    Step("Press key 1: output 1 off", _press(1)),
    Step("New fuse; press key 4: RESET, output 4 off",
         lambda emu, kp, kb: (emu.run(lambda now: kb.replace_fuse(4, now)),
                              _press(4)(emu, kp, kb))),
    Step("Press key 4: output 4 on again", _press(4)),
    Step("Power-cycle the keypad: the driver restarts it and restores its LEDs",
         lambda emu, kp, kb: emu.power_cycle(kp)),
)


def _frame_line(row: Row) -> str:
    frame = row.event.frame
    return f"{frame.can_id:03X} {frame.data.hex(' ').upper():<23} {row.text()}"


def _state_line(keypad: dict[str, Any], keybox: dict[str, Any]) -> str:
    """What the devices show, as one line: "keys lit: 1 green, 4 ~red; outputs HIGH: [1]"."""
    lit = []
    for key in keypad["keys"]:
        a, b = key["phases"]
        if a == b != "off":
            lit.append(f"{key['key']} {a}")
        elif a != b:
            lit.append(f"{key['key']} ~{b if a == 'off' else a}" if "off" in (a, b)
                       else f"{key['key']} {a}/{b}")
    high = [p["pin"] for p in keybox["pins"] if p["state"] == "high"]
    faults = [p["pin"] for p in keybox["pins"] if p["state"] == "fault"]
    return (f"  keys lit: {', '.join(lit) or 'none'}; outputs HIGH: {high}"
            + (f"; FAULT: {faults}" if faults else ""))


def _view(header: str, title: str, keypad: dict[str, Any], keybox: dict[str, Any],
          log: EventLog, grid: tuple[tuple[int, ...], ...]) -> Group:
    keys = keypad["keys"]
    pins = keybox["pins"]
    return Group(
        Text(header, style="cyan"),
        Text(title, style="bold"),
        keypad_panel(((k["key"], *k["phases"], k["pressed"]) for k in keys),
                     f"keypad 15h, {keypad['nmt_state']} (~ blinking, a/b alternating)", grid),
        keybox_panel(((p["pin"], p["state"], p["fuse"] == "blown", p["pwm_percent"])
                      for p in pins),
                     f"Keybox 0Ch, {keybox['nmt_state']}"),
        Panel(Text("\n".join(_frame_line(row) for row in list(log.rows)), style="grey70",
                   no_wrap=True, overflow="ellipsis"),
              title="last frames on the bus", expand=False),
    )


class _Show:
    """What the demo shows: on a terminal a live picture redrawn after each step; elsewhere
    lines (the narration, each frame that is news, after each step what the devices show)."""

    def __init__(self, console: Console, emulator: Emulator, keypad: KeypadTwin,
                 keybox: KeyboxTwin) -> None:
        self.console, self.emulator, self.keypad, self.keybox = console, emulator, keypad, keybox
        self.decoder = Decoder({t.node_id: t.description for t in (keypad, keybox)})
        self.log = EventLog(10, self.decoder)  # heartbeats (the controller's too) and
        self.frames = 0                        # periodic frames fold
        self.lines = not console.is_terminal  # a pipe or a file: lines, not a live picture
        self.clock = Clock(start=time.monotonic())  # the emulator's clock, from its start
        self.live: Live | None = None
        self.header = ""
        emulator.on_frame = self.record

    def record(self, frame: Frame, sent: bool, now: float) -> None:
        self.frames += 1
        row = self.log.add(self.decoder.decode(frame, now))
        if row.count == 1:  # news: not a repeated heartbeat or periodic frame
            self.say(f"{self.clock(now):>7} {_frame_line(row)}")

    def say(self, text: str) -> None:
        if self.lines:
            self.console.out(text, highlight=False)

    def draw(self, title: str) -> None:
        keypad = self.emulator.snapshot(self.keypad)
        keybox = self.emulator.snapshot(self.keybox)
        if self.lines:
            self.say(_state_line(keypad, keybox))
        elif self.live is not None:
            self.live.update(_view(self.header, title, keypad, keybox, self.log,
                                   self.keypad.description.face.grid), refresh=True)


def run_demo(console: Console, pause: float = 0.6, web: str | None = None,
             wait: Callable[[], None] | None = None) -> int:
    """The scripted demo; with ``web`` the panel is served and the controller keeps running
    until ``wait`` returns (default: until Ctrl-C)."""
    address = None if web is None else panel_address(web)
    channel = f"blinkcan-demo-{uuid.uuid4().hex[:8]}"
    device_bus, host_bus = (can.Bus(interface="virtual", channel=channel) for _ in range(2))
    keypad_twin, keybox_twin = KeypadTwin(node_id=0x15), KeyboxTwin(node_id=0x0C)
    emulator = Emulator(device_bus, [keypad_twin, keybox_twin])
    show = _Show(console, emulator, keypad_twin, keybox_twin)
    try:
        with emulator, panel(emulator, address, console), HostBus(host_bus) as host, \
                Live(console=console, auto_refresh=False, transient=show.lines) as live:
            show.live = live
            keypad = Keypad(host)
            # outputs off if this controller dies; a second, not less: on a loaded machine
            # this one process's threads (twins, controller, screen) can starve the host's
            # heartbeat for a few hundred ms, and the demo would show a trip nobody caused
            keybox = Keybox(host, watchdog=1.0)
            identity = keypad.identity()
            show.header = (f"Controller: keypad {identity.model_id} firmware "
                           f"{identity.software_version}, Keybox {keybox.identity().model_id} "
                           "watching the controller's heartbeat. Key N toggles output N.")
            controller = Controller(keypad, keybox)
            show.say(show.header)
            show.say("== The keypad plays its startup LED show")
            show.draw("The keypad plays its startup LED show")
            time.sleep(max(pause * 4, 0.05))
            for step in SCRIPT:
                show.say(f"== {step.title}")
                step.act(emulator, keypad_twin, keybox_twin)
                controller.settle()
                time.sleep(max(pause, 0.05))
                show.draw(step.title)
            if pause:  # the keypad plays its show again after the power cycle, then the LEDs
                time.sleep(2.6)
                show.draw(SCRIPT[-1].title)
            states = keybox.states()
            if web is not None:  # the script's result, then the panel; the end comes after
                live.stop()
                console.line()
                console.print(f"after the script: outputs HIGH {_high(states)}")
                console.print("the controller keeps running with the panel; Ctrl-C stops")
                (wait or until_interrupted)()
                states = keybox.states()  # what was done on the panel counts too
            controller.stop()
            keypad.close()
            keybox.close()
    finally:
        host_bus.shutdown()
        device_bus.shutdown()
    console.print(f"\n{show.frames} frames on the bus; outputs HIGH at the end: "
                  f"{_high(states)}")
    return 0


def _high(states: dict[int, str]) -> list[int]:
    return sorted(pin for pin, state in states.items() if state == "high")


@click.command("demo", epilog=f"MODEL: {model_names()}.")
@click.option("--pause", type=Seconds(maximum=60.0), default=0.6, show_default=True,
              help="Seconds between the scripted steps.")
@click.option("--web", is_flag=False, flag_value="127.0.0.1:8080", default=None,
              metavar="[HOST:PORT]", help="Serve the front panel too, and keep running.")
@click.option("--model", "spec", default=None, metavar="MODEL[@GENERATION]",
              help="A short scripted scenario of this one model instead: started, then "
                   "everything its face has done once (keys, knobs, inputs, fuses, power).")
@click.option("--protocol", type=click.Choice(["canopen", "j1939"]), default="canopen",
              show_default=True, help="The protocol the --model device speaks.")
def command(pause: float, web: str | None, spec: str | None, protocol: str) -> None:
    """A controller on a keypad and a Keybox twin: key N toggles output N, shown live."""
    if spec is None and protocol == "canopen":
        raise SystemExit(run_demo(output_console(), pause, web))
    console = output_console()
    if spec is None:  # the model that speaks it, as a user means (one: the PKP-2600-SI)
        found = models_speaking(protocol)
        if len(found) != 1:
            raise click.UsageError(f"--protocol {protocol} needs --model: "
                                   f"{', '.join(m.name for m in found) or 'no model'} speak it")
        spec = found[0].name
        console.out(f"== --protocol {protocol} with no --model: the "
                    f"{found[0].description().title}, the one model that speaks "
                    f"{protocol.upper()}", highlight=False)
    try:
        parse_spec(spec)
    except ValueError as error:
        raise click.BadParameter(str(error), param_hint="--model") from None
    raise SystemExit(run_model_demo(console, spec, protocol, pause, web))


def models_speaking(protocol: str) -> list[Model]:
    """The registered models with ``protocol`` in a generation's features."""
    return [m for m in models()
            if any(protocol in m.description(g).features for g in m.generations)]
