"""``blinkcan demo``: a keypad and a Keybox twin on a virtual bus, driven by a scripted host.

Every step sends the frames the manual prints and shows what came back, with its meaning.
"""

from __future__ import annotations

import time
import uuid
from collections.abc import Callable
from dataclasses import dataclass

import can
import click
from rich.console import Console
from rich.table import Table
from rich.text import Text

from blinkcan.decode import FrameDescriber
from blinkcan.protocol.frame import Frame
from blinkcan.runtime import Emulator, to_frame, to_message
from blinkcan.twin import KeyboxTwin, KeypadTwin

SETTLE_S = 0.03
_STYLE = {"off": "grey35", "red": "red", "green": "green", "blue": "blue", "yellow": "yellow",
          "cyan": "cyan", "magenta": "magenta", "white": "white"}


@dataclass(frozen=True)
class Step:
    title: str
    frames: tuple[str, ...] = ()  # "615 40 00 10 00 00 00 00 00"
    action: Callable[[Emulator, KeypadTwin, KeyboxTwin], object] | None = None
    wait: float = SETTLE_S


def _f(text: str) -> Frame:
    ident, *data = text.split()
    return Frame(int(ident, 16), bytes(int(b, 16) for b in data))


SCRIPT = (
    Step("Read the device type (PKP §26)", ("615 40 00 10 00 00 00 00 00",)),
    Step("Read the device name, segmented (PKP §28)",
         ("615 40 08 10 00 00 00 00 00", "615 60 00 00 00 00 00 00 00",
          "615 70 00 00 00 00 00 00 00")),
    Step("Read the firmware version: this firmware sends it reversed (errata P6)",
         ("615 40 0A 10 00 00 00 00 00",)),
    Step("Read the vendor id (PKP §32)", ("615 40 18 10 01 00 00 00 00",)),
    Step("Switch the startup LED show off, stored (PKP §23)", ("615 2F 14 20 00 00 00 00 00",)),
    Step("Heartbeat every 200 ms, stored (PKP §25)", ("615 2B 17 10 00 C8 00 00 00",)),
    Step("Reset the node: boot-up, no show this time (PKP §6)", ("000 81 15",), wait=0.25),
    Step("Start the keypad (PKP §4)", ("000 01 15",), wait=0.22),
    Step("Press key 4 (PKP §10)", action=lambda emu, kp, kb: emu.press(kp, 4)),
    Step("Release key 4", action=lambda emu, kp, kb: emu.release(kp, 4)),
    Step("Red LEDs 2 and 7, green LED 5 on (PKP §11)", ("215 42 00 01 00 00 00 00 00",)),
    Step("Key 1 red, then blinking red/green alternately (errata P9)",
         ("215 43 00 01 00 00 00 00 00", "315 01 10 00 00 00 00 00 00")),
    Step("Blue backlight at 50 % (PKP §18c, §14)",
         ("615 2F 03 20 03 03 00 00 00", "515 20 00 00 00 00 00 00 00")),
    Step("Hold key 12 and read the keys by SDO (PKP §15)",
         ("615 40 00 20 01 00 00 00 00",), action=lambda emu, kp, kb: emu.press(kp, 12)),
    Step("Ask for object 1001h, which this keypad lacks (PKP §27)",
         ("615 40 01 10 00 00 00 00 00",)),
    Step("Keybox: read the model, one segment (KBX §35)",
         ("60C 40 0B 10 00 00 00 00 00", "60C 60 00 00 00 00 00 00 00")),
    Step("Keybox: start it, then outputs 1 and 4 HIGH (KBX §11, §17)",
         ("000 01 0C", "20C 00 00 09 00 00 00 00 00")),
    Step("Keybox: the fuse of output 4 blows, the Keybox reports it (KBX §18)",
         action=lambda emu, kp, kb: emu.run(lambda now: kb.blow_fuse(4, now))),
    Step("Keybox: OFF does not clear the FAULT; who is in FAULT? (KBX §21, errata K12)",
         ("20C 08 00 00 00 00 00 00 00", "60C 40 08 20 03 00 00 00 00")),
    Step("Keybox: new fuse, RESET output 4 (KBX §19)",
         ("60C 2F 01 20 04 02 00 00 00",),
         action=lambda emu, kp, kb: emu.run(lambda now: kb.replace_fuse(4, now))),
    Step("Stop both devices: they stay silent (PKP §7, KBX §14)",
         ("000 02 00", "615 40 00 10 00 00 00 00 00", "60C 40 00 10 00 00 00 00 00"),
         wait=0.05),
)


def _collect(host: can.BusABC, until: float) -> list[tuple[Frame, float]]:
    """Frames the host receives until ``until``, each with the time it arrived."""
    frames = []
    while (left := until - time.monotonic()) > 0:
        message = host.recv(left)
        if message is not None and (frame := to_frame(message)) is not None:
            frames.append((frame, time.monotonic()))
    return frames


def _keypad_grid(snapshot: dict[str, object]) -> Table:
    grid = Table(show_header=False, box=None, padding=(0, 1))
    keys = snapshot["keys"]
    assert isinstance(keys, list)
    for row in (keys[:6], keys[6:]):
        cells = []
        for key in row:
            colour, blink = key["colour"], key["blink_colour"]
            label = Text(f"[{key['key']:>2}]", style=f"bold {_STYLE[colour]}")
            if blink != "off":
                label.append("~", style=_STYLE[blink])
            cells.append(label)
        grid.add_row(*cells)
    return grid


def run_demo(console: Console) -> int:
    channel = f"blinkcan-demo-{uuid.uuid4().hex[:8]}"
    device_bus = can.Bus(interface="virtual", channel=channel)
    host = can.Bus(interface="virtual", channel=channel)
    keypad, keybox = KeypadTwin(node_id=0x15), KeyboxTwin(node_id=0x0C)
    describer = FrameDescriber({t.node_id: t.description for t in (keypad, keybox)})
    table = Table(title="PKP-2600-SI keypad (15h) and Keybox (0Ch) twins on a virtual CAN bus",
                  title_justify="left")
    for column in ("t ms", "", "id", "data", "meaning"):
        table.add_column(column, no_wrap=column != "meaning")
    start = time.monotonic()

    def show(frame: Frame, sent_by_host: bool, at: float | None = None) -> None:
        arrow = Text("host ->", style="cyan") if sent_by_host else Text("   <- ", style="yellow")
        at = time.monotonic() if at is None else at
        table.add_row(f"{(at - start) * 1000:6.0f}", arrow, f"{frame.can_id:03X}",
                      frame.data.hex(" ").upper(), describer.describe(frame))

    try:
        with Emulator(device_bus, [keypad, keybox]) as emulator:
            table.add_section()
            table.add_row("", "", "", "", Text("Power on", style="bold"))
            for frame, at in _collect(host, time.monotonic() + SETTLE_S):
                show(frame, False, at)
            for step in SCRIPT:
                table.add_section()
                table.add_row("", "", "", "", Text(step.title, style="bold"))
                if step.action is not None:
                    step.action(emulator, keypad, keybox)
                for text in step.frames:
                    frame = _f(text)
                    host.send(to_message(frame))
                    show(frame, True)
                    for reply, at in _collect(host, time.monotonic() + step.wait):
                        show(reply, False, at)
                if not step.frames:
                    for frame, at in _collect(host, time.monotonic() + step.wait):
                        show(frame, False, at)
            snapshot = emulator.snapshot(keypad)
            keybox_snapshot = emulator.snapshot(keybox)
    finally:
        host.shutdown()
        device_bus.shutdown()
    console.print(table)
    console.print("\n[bold]What the keypad shows now[/] (~ = blinking in that colour):")
    console.print(_keypad_grid(snapshot))
    backlight = snapshot["backlight"]
    console.print(f"backlight {backlight['colour']} at {backlight['level']}/63, "
                  f"NMT {snapshot['nmt_state']}, node {snapshot['node_id']:02X}h, "
                  f"{snapshot['bitrate'] // 1000} kbit/s")
    console.print("\n[bold]Keybox outputs[/] (stopped: fail-safe OFF; FAULT stays latched):")
    console.print(_keybox_row(keybox_snapshot))
    return 0


def _keybox_row(snapshot: dict[str, object]) -> Text:
    row = Text()
    pins = snapshot["pins"]
    assert isinstance(pins, list)
    styles = {"off": "grey50", "high": "bold green", "fault": "bold red"}
    for pin in pins:
        row.append(f" {pin['pin']}:{pin['state'].upper()}", style=styles[pin["state"]])
        if pin["fuse"] == "blown":
            row.append("(fuse blown)", style="red")
    return row


@click.command("demo")
def command() -> None:
    """A keypad and a Keybox twin on a virtual bus, driven by a scripted host."""
    raise SystemExit(run_demo(Console(highlight=False)))
