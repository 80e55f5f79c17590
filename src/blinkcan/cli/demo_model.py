"""``blinkcan demo --model NAME``: a short scripted scenario for one registered model.

The model's twin runs in an Emulator on a virtual bus; a host starts it (NMT, when it speaks
CANopen), then, through the model's own driver (the registry's), commands what its face shows:
an LED steady and one blinking, a knob's ring LEDs, an output switched on and one driven with
PWM (:func:`host_steps`). Then a hand does to it, once each, everything its face has
(twin/actions.py: press and release a key, turn a knob, set an input, blow and replace a fuse,
switch the power off and on): the fuse it blows is the output's that is on, so the fault
shows. What a step leaves for later is shown after it (:func:`_after`): a new fuse leaves
FAULT latched, so the host then resets the output; a voltage shows in the next periodic
analog PDO, which the step waits for. A new model's face brings its scenario with it. Every
frame is a line: seconds since the start, the direction, the frame and its meaning. The
emulator runs in real time; ``pause`` is the time between the steps.
"""

from __future__ import annotations

import contextlib
import inspect
import threading
import time
import uuid
from collections.abc import Callable
from functools import partial
from typing import Any

import can
from rich.console import Console

from blinkcan.cli.clock import Clock
from blinkcan.cli.emulate import build_twins, decoder_devices, panel, panel_address
from blinkcan.decode import Decoder
from blinkcan.devices.model import Face
from blinkcan.host import HostBus
from blinkcan.host.j1939_keypad import scan_j1939
from blinkcan.host.registry import driver_class
from blinkcan.host.scan import scan
from blinkcan.protocol.frame import Frame
from blinkcan.protocol.nmt import NmtCommand, nmt_frame
from blinkcan.runtime import Emulator
from blinkcan.twin.actions import Action, actions_of
from blinkcan.twin.base import CanopenTwin
from blinkcan.twin.keypad import KeypadTwin

#: the value a scripted step gives an argument where its range's first is not the one to show
_SHOWN: dict[str, Callable[[float, float], float]] = {
    "ticks": lambda low, high: min(high, 4),  # a quarter turn clockwise
    "volts": lambda low, high: round((low + high) / 2, 2),
    "level": lambda low, high: high,
}
#: how long the twin may take to become operational after the host's NMT start
_START_TIMEOUT = 5.0
#: the heartbeat period the host asks of a keypad in J1939 mode, in seconds (§18)
_J1939_HEARTBEAT = 0.5


def scripted_steps(twin: CanopenTwin) -> list[tuple[str, Action, dict[str, Any]]]:
    """(title, action, arguments) for every action the twin's face has, in the table's order,
    each with the first value of its range (or :data:`_SHOWN`'s)."""
    face = twin.description.face
    steps = []
    for action in actions_of(face):
        values: dict[str, Any] = {}
        for argument in action.arguments:
            low, high = argument.bounds(face)
            shown = _SHOWN.get(argument.name)
            values[argument.name] = low if shown is None else shown(low, high)
        named = ", ".join(f"{name} {value}" for name, value in values.items())
        steps.append((f"{action.doing}{f' ({named})' if named else ''}", action, values))
    return steps


def host_steps(driver: Any, face: Face) -> list[tuple[str, Callable[[], object]]]:
    """(title, command) for what a controller shows on the model, read from its face: the
    first LED key lit steadily and the next one blinking, a knob's ring LEDs, the first output
    switched on (the pin whose fuse the hand then blows) and the first PWM output at half
    duty; ``driver`` is the model's driver, which sends each command."""
    steps: list[tuple[str, Callable[[], object]]] = []
    colours = face.led_colours
    if face.led_keys and colours:
        key, steady = face.led_keys[0], colours[min(1, len(colours) - 1)]
        steps.append((f"the host lights key {key}'s LED {steady}",
                      partial(driver.set_led, key, steady)))
        if len(face.led_keys) > 1:
            other, blink = face.led_keys[1], colours[0]
            steps.append((f"the host makes key {other}'s LED blink {blink}",
                          partial(driver.set_led, other, "off", blink=blink)))
    for encoder in face.encoders:
        if encoder.ring_leds:
            leds = encoder.ring_leds[:4]
            steps.append((f"the host lights ring LEDs {leds[0]}..{leds[-1]} of knob "
                          f"{encoder.number}", partial(driver.set_ring, encoder.number, leds)))
    if face.pins:
        pin = face.pin_numbers[0]
        steps.append((f"the host switches output {pin} on", partial(driver.on, pin)))
    if face.pwm_pins and face.pwm_duty_max:
        pin, duty = face.pwm_pins[0], face.pwm_duty_max // 2
        steps.append((f"the host drives output {pin} with PWM, duty {duty} of "
                      f"{face.pwm_duty_max}", partial(driver.set_pwm, (pin,), duty)))
    return steps


def _driver(twin: CanopenTwin, host: HostBus, protocol: str) -> Any:
    """The model's driver on ``host``, not asking again what the scan found (nor starting
    the device: the demo shows that step itself)."""
    cls = driver_class(twin.description.model)
    options: dict[str, Any] = {"verify": False, "start": False}
    parameters = inspect.signature(cls).parameters
    if "model" in parameters:
        options["model"] = twin.description.model
    if "generation" in parameters:  # the LED objects differ by generation (PKP rev 1.5)
        options["generation"] = twin.description.generation
    if protocol != "canopen":
        options["protocol"] = protocol
    return cls(host, twin.node_id, **options)


def run_model_demo(console: Console, spec: str, protocol: str = "canopen",
                   pause: float = 0.6, web: str | None = None,
                   wait: Callable[[], None] | None = None) -> int:
    """The scenario of the model ``spec`` ("pkp-3500-mt", "keypad@1.5"); see the module."""
    address = None if web is None else panel_address(web)
    twins = build_twins((spec,), None, None, "firmware", protocol=protocol)
    twin = twins[0]
    decoder = Decoder(decoder_devices(twins))
    clock = Clock(start=time.monotonic())
    frames = heard = told = 0

    def show(frame: Frame, sent: bool, now: float) -> None:
        nonlocal frames, heard, told
        console.out(f"{clock(now):>7} {'<' if sent else '>'} {frame.can_id:03X} "
                    f"{frame.data.hex(' ').upper():<23} {decoder.text(frame, now)}",
                    highlight=False)
        frames += 1
        heard += not sent  # a frame of the host's, shown
        told += sent  # a frame of the device's, shown

    def told_since(count: int) -> Callable[[], bool]:
        return lambda: told > count

    def host_step(step: str, command: Callable[[], object]) -> None:
        console.out(f"== {step}", highlight=False)
        before = heard
        command()
        host.run(lambda: None)  # what it sent is on the bus...
        _shown(lambda: heard > before, lambda: frames)  # ...and shown

    channel = f"blinkcan-demo-{uuid.uuid4().hex[:8]}"
    title = twin.description.title
    try:
        with can.Bus(interface="virtual", channel=channel) as device_bus, \
                can.Bus(interface="virtual", channel=channel) as host_bus, \
                HostBus(host_bus) as host:
            emulator = Emulator(device_bus, twins)
            emulator.on_frame = show
            console.out(f"== {title} at {_where(twin)} is powered on", highlight=False)
            with emulator, panel(emulator, address, console):
                _started(console, emulator, twin, host, protocol)
                driver = _driver(twin, host, protocol)  # it restores what it showed
                try:  # after the power cycle, as a controller does
                    booted = _watching_power_on(driver, protocol, pause, host_step, partial(
                        _shown, told_since(told), lambda: frames, limit=2 * _J1939_HEARTBEAT))
                    for step, command in host_steps(driver, twin.description.face):
                        time.sleep(pause)
                        host_step(step, command)
                    for step, action, values in scripted_steps(twin):
                        time.sleep(pause)
                        console.out(f"== {step}", highlight=False)
                        emulator.run(partial(_perform, action, twin, values))
                        _after(action, values, driver, host_step, partial(
                            _shown, told_since(told), lambda: frames, limit=1.0), booted)
                    _last_shown(emulator, pause, lambda: frames)
                    if web is not None:
                        console.out("the twin keeps running with the panel; Ctrl-C stops",
                                    highlight=False)
                        (wait or until_interrupted)()
                finally:
                    driver.close()
    finally:
        for each in twins:
            each.close()
    console.out(f"\n{frames} frames on the bus ({title})", highlight=False)
    return 0


def _where(twin: CanopenTwin) -> str:
    """"node 15h (CANopen)", or a keypad in J1939 mode's source address: "address 21h
    (J1939)" (its node id is only kept for a switch back to CANopen)."""
    if isinstance(twin, KeypadTwin) and twin.protocol == "j1939":
        return f"address {twin.j1939.settings['source_address']:02X}h (J1939)"
    return f"node {twin.node_id:02X}h (CANopen)"


def _last_shown(emulator: Emulator, pause: float, count: Callable[[], int]) -> None:
    """After the last step: what it sent is shown, and the driver's answer."""
    time.sleep(pause)
    emulator.run(lambda now: None)
    _shown(lambda: True, count)


def _watching_power_on(driver: Any, protocol: str, pause: float,
                       host_step: Callable[[str, Callable[[], object]], None],
                       first_heartbeat: Callable[[], None]) -> threading.Event | None:
    """A keypad in J1939 mode says nothing when it powers on (its heartbeat and address claim
    are off by default, spec/pkp-2600-si-j1939.md §5): the host turns its heartbeat on (§18),
    whose counter back at 00h the driver takes for a power-on ("boot-up", and the LEDs sent
    again), and waits for the first, the one the next follow. The event is set at the driver's
    "boot-up"; None in CANopen, where the boot-up frame says it."""
    if protocol == "canopen":
        return None
    booted = threading.Event()
    driver.on_health(lambda event: booted.set() if event.kind == "boot-up" else None)
    time.sleep(pause)
    host_step(f"the host turns the keypad's heartbeat on (every {_J1939_HEARTBEAT:g} s, §18): "
              "a counter back at 00h is a power-on",
              partial(driver.monitor_heartbeat, _J1939_HEARTBEAT))
    first_heartbeat()
    return booted


def _after(action: Action, values: dict[str, Any], driver: Any,
           host_step: Callable[[str, Callable[[], object]], None],
           next_frame: Callable[[], None], booted: threading.Event | None = None) -> None:
    """Show what a hand's step left for later: the host's command that completes it
    (``host_step(title, command)``), or the device's next frame (``next_frame()``, counted
    from after the step ran)."""
    if action.name == "replace_fuse":  # KBX errata K12: FAULT stays latched until RESET
        pin = values["pin"]
        host_step(f"the host resets output {pin} (a new fuse leaves FAULT latched until "
                  "RESET, 2001h value 02h)", partial(driver.reset, pin))
    elif action.name == "set_analog":  # MT §14: a periodic PDO (80 ms), the next one tells
        next_frame()
    elif action.name == "power_on" and booted is not None:  # J1939: the next heartbeat tells
        host_step("the driver hears the power-on (its heartbeat counter back at 00h) and "
                  "shows the LEDs again", partial(booted.wait, 2 * _J1939_HEARTBEAT))


def _shown(first: Callable[[], bool], count: Callable[[], int], quiet: float = 0.03,
           limit: float = 5.0) -> None:
    """Until ``first()`` holds (a frame of the host's shown: every command sends one), then
    until ``count()`` (frames shown) stood still for ``quiet`` seconds; at most ``limit``
    seconds in all. The emulator's reader thread shows the host's frames as it reads them,
    so the next step's title comes after them."""
    end = time.monotonic() + limit
    while not first() and time.monotonic() < end:
        time.sleep(0.002)
    seen, since = count(), time.monotonic()
    while time.monotonic() < end and time.monotonic() - since < quiet:
        time.sleep(0.005)
        if count() != seen:
            seen, since = count(), time.monotonic()


def _started(console: Console, emulator: Emulator, twin: CanopenTwin, host: HostBus,
             protocol: str) -> None:
    """The host finds the device as ``blinkcan scan`` does and, in CANopen, starts it."""
    if protocol != "canopen":
        console.out("== the host asks every J1939 keypad for its software revision",
                    highlight=False)
        revisions = [found.software_revision for found in scan_j1939(host, listen=0.2)]
        console.out(f"   found: {', '.join(map(str, revisions)) or 'none'}", highlight=False)
        return
    console.out("== the host reads its identity (1000h, 1018h, 100Bh)", highlight=False)
    found = scan(host, listen=0.05, node_ids=range(twin.node_id, twin.node_id + 1))
    named = ", ".join(f"{device.model_id} {device.software_version}" for device in found)
    console.out(f"   found: {named or 'none'}", highlight=False)
    console.out("== the host starts it (NMT start)", highlight=False)
    start = nmt_frame(NmtCommand.START, twin.node_id)
    host.send(start)
    deadline = time.monotonic() + _START_TIMEOUT
    while emulator.snapshot(twin)["nmt_state"] != "operational" \
            and time.monotonic() < deadline:
        time.sleep(0.01)


def _perform(action: Action, twin: CanopenTwin, values: dict[str, Any], now: float
             ) -> object:
    return action.perform(twin, values, now)


def until_interrupted() -> None:
    """Until Ctrl-C. The wait wakes every half second, as emulate's does: one endless wait
    could miss a signal that came right after start-up."""
    never = threading.Event()
    with contextlib.suppress(KeyboardInterrupt):
        while not never.wait(0.5):
            pass
