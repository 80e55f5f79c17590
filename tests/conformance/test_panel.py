"""``blinkcan emulate`` runs every registered case, and its front panel (``--web``) draws each
model's face in a real browser (issue 19): every key, LED, knob, ring LED, input and output the
description declares is on the page, no more, and clicking one of each kind of input reaches
the twin (the page then draws what the twin reports, and the device's frames say it on the bus).

The emulators run as ``blinkcan emulate`` does for a user, in child processes on a
``udp_multicast`` group of their own (hop limit 0); this process is the host on that group.
Every CANopen case of one quirk profile shares one emulator (a node id each); a keypad in
another protocol runs alone, since those twins all start at one source address. The panel is
checked for every model, generation and protocol in one quirk profile (what it draws is the
same in each, checked here too), with one Chromium (Debian's, driven by Playwright as in
tests/web/) for all of them."""

from __future__ import annotations

import contextlib
import ctypes
import os
import random
import shutil
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from importlib.util import find_spec
from typing import Any

import can
import pytest

from blinkcan.decode import Decoder
from blinkcan.devices.model import QUIRK_PROFILES, Face
from blinkcan.protocol import Frame
from blinkcan.runtime import to_frame, to_message
from tests.conformance.cases import CASES, Case, cases
from tests.processes import multicast_bus, stop

pytestmark = pytest.mark.multiprocess

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
WEB = find_spec("starlette") is not None and find_spec("uvicorn") is not None
# bounds only a failure reaches: each wait ends as soon as what it waits for happens, and a
# machine running 8 test suites on 2 cores (load 30) took more than 10 s to draw a click
START_TIMEOUT_S = 180.0  # a loaded machine starts eight Python processes at once
WAIT_MS = 60_000  # every Playwright wait (the page's default timeout too)
HEARD_S = 60.0  # frames on the bus


@dataclass
class Emulated:
    """One ``blinkcan emulate`` child: the cases it runs (at which node id), everything it
    printed, its panel's address and a host bus on its multicast group."""

    nodes: dict[str, int]
    child: subprocess.Popen[str]
    host: can.BusABC
    web: bool
    lines: list[str] = field(default_factory=list)
    page: Any = None

    @property
    def url(self) -> str | None:
        for line in list(self.lines):
            if line.startswith("front panel: "):
                return line.split(": ", 1)[1].strip()
        return None

    @property
    def banner(self) -> str:
        """What it printed, its line breaks undone."""
        return " ".join(" ".join(self.lines).split())


def _groups() -> list[list[Case]]:
    """The cases that share one emulator: each quirk profile's CANopen cases; each case of
    another protocol alone."""
    shared: dict[str, list[Case]] = {}
    alone: list[list[Case]] = []
    for case in CASES:
        if case.canopen:
            shared.setdefault(case.quirks, []).append(case)
        else:
            alone.append([case])
    return [*shared.values(), *alone]




PR_SET_PDEATHSIG = 1  # Linux prctl(2)


def _end_with_this_process() -> None:
    """In the child before it runs: a SIGTERM when this test process ends, however it ends (a
    killed test run leaves no emulator behind); elsewhere than Linux, the fixture's teardown."""
    with contextlib.suppress(OSError, AttributeError):
        ctypes.CDLL(None).prctl(PR_SET_PDEATHSIG, signal.SIGTERM)


def _start(group: list[Case]) -> Emulated:
    channel = f"239.74.{random.randint(1, 254)}.{random.randint(1, 254)}"
    port = random.randint(40000, 60000)
    host = multicast_bus(channel, port)
    several = len(group) > 1
    nodes = {str(case): (number if several else case.model.default_node_id)
             for number, case in enumerate(group, start=1)}
    # a J1939 keypad runs alone at its default address (DEVICE:ADDR would be its address)
    specs = [f"{case.spec}:{nodes[str(case)]}" if case.canopen else case.spec for case in group]
    first = group[0]
    web = WEB and first.quirks == QUIRK_PROFILES[0]  # the quirk profile the panel is checked in
    environment = {name: value for name, value in os.environ.items()
                   if not name.startswith("CAN_")}  # the bus is named below
    child = subprocess.Popen(
        [sys.executable, "-m", "blinkcan", "emulate", *specs, "--quirks", first.quirks,
         "--protocol", first.protocol, *(["--web", "127.0.0.1:0"] if web else []), "-q",
         "-i", "udp_multicast", "-c", channel, "--bus-kwargs", f"port={port}", "hop_limit=0"],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
        env={**environment, "PYTHONUNBUFFERED": "1", "COLUMNS": "200"},
        preexec_fn=_end_with_this_process)  # noqa: PLW1509 (no lock taken: one libc call)
    emulated = Emulated(nodes, child, host, web)
    stdout = child.stdout
    assert stdout is not None
    threading.Thread(target=lambda: emulated.lines.extend(stdout), daemon=True).start()
    return emulated


def _ready(emulated: Emulated) -> None:
    """Wait until the child says it runs (and where its panel is, if it serves one)."""
    end = time.monotonic() + START_TIMEOUT_S
    while not (emulated.url if emulated.web else "Ctrl-C stops" in emulated.banner):
        assert emulated.child.poll() is None, f"emulate ended: {emulated.banner}"
        assert time.monotonic() < end, f"emulate did not start: {emulated.banner}"
        time.sleep(0.05)


@pytest.fixture(scope="module")
def emulators() -> Iterator[dict[str, Emulated]]:
    """Every case's emulator (started together), by case."""
    running: list[Emulated] = []
    try:
        for group in _groups():
            running.append(_start(group))
        for emulated in running:
            _ready(emulated)
        yield {name: emulated for emulated in running for name in emulated.nodes}
    finally:
        for emulated in running:
            stop(emulated.child)
            emulated.host.shutdown()


@pytest.mark.parametrize("case", cases("emulate"))
def test_emulate_runs_it(emulators: dict[str, Emulated], case: Case) -> None:
    emulated = emulators[str(case)]
    description = case.description
    assert emulated.child.poll() is None, emulated.banner
    assert f"{description.title} " in emulated.banner
    assert description.edition in emulated.banner
    if not case.canopen:
        assert f"({case.protocol.upper()})" in emulated.banner


# -- the panel in Chromium ------------------------------------------------------------------------

@pytest.fixture(scope="module")
def browser() -> Iterator[Any]:
    if CHROMIUM is None:
        pytest.skip("Debian's chromium is not installed (apt-get install chromium); "
                    ".ci/run installs it")
    if not WEB:
        pytest.skip("the web extra is not installed")
    playwright_api = pytest.importorskip("playwright.sync_api",
                                         reason="playwright is not installed")
    with playwright_api.sync_playwright() as playwright:
        launched = playwright.chromium.launch(
            executable_path=CHROMIUM,
            args=["--no-sandbox", "--disable-gpu", "--disable-background-networking"])
        try:
            yield launched
        finally:
            launched.close()


def _page(browser: Any, emulated: Emulated) -> Any:
    """The emulator's panel, open with every device drawn and every CANopen device started."""
    if emulated.page is None:
        page = browser.new_page(viewport={"width": 1600, "height": 1000})
        page.set_default_timeout(WAIT_MS)  # clicks, fills, navigation: not Playwright's 30 s
        page.goto(emulated.url)
        for node in emulated.nodes.values():
            page.wait_for_selector(f'[data-test="device-{node}"]', timeout=WAIT_MS)
        emulated.host.send(to_message(Frame(0x000, b"\x01\x00")))  # NMT: start them all
        emulated.page = page
    return emulated.page


def _state(page: Any, node: int) -> dict[str, Any]:
    """The device's state as the panel serves it (the twin's snapshot)."""
    devices = page.evaluate("async () => (await (await fetch('/api/state')).json()).devices")
    return next(device for device in devices if device["node_id"] == node)


def _drawn(face: Face) -> dict[str, str]:
    """What the page must show for a face: its name -> a selector inside the device."""
    found = {f"key {key}": f'[data-test="key-{key}"]' for key in face.key_numbers}
    found |= {f"LED of key {key}": f'[data-test="key-{key}"] [data-test="led-{key}"]'
              for key in face.led_keys}
    for encoder in face.encoders:
        knob = f'[data-test="key-{encoder.key}"]'
        found[f"knob {encoder.number}"] = f"{knob}.knob"
        found[f"counter of knob {encoder.number}"] = (
            f'{knob} [data-test="counter-{encoder.number}"]')
        found |= {f"ring LED {led}": f'{knob} [data-test="ring-led-{led}"]'
                  for led in encoder.ring_leds}
    found |= {f"analog input {n}": f'[data-test="analog-{n}"]' for n in range(face.analog_inputs)}
    found |= {f"digital input {n}": f'[data-test="digital-{n}"]'
              for n in range(face.digital_inputs)}
    for pin in face.pin_numbers:
        found |= {f"output {pin}": f'[data-test="state-{pin}"]',
                  f"fuse of output {pin}": f'[data-test="fuse-{pin}"]',
                  f"input of output {pin}": f'[data-test="input-{pin}"]'}
    return found


#: data-test prefixes the page numbers per face part -> how many of them the face has
_COUNTED: dict[str, Callable[[Face], int]] = {
    "key-": lambda f: f.keys,
    "led-": lambda f: len(f.led_keys),
    "ring-led-": lambda f: sum(len(e.ring_leds) for e in f.encoders),
    "analog-": lambda f: f.analog_inputs,
    "digital-": lambda f: f.digital_inputs,
    "state-": lambda f: f.pins,
}


def _heard(emulated: Emulated, decoder: Decoder, texts: list[str]) -> list[str]:
    """Which of ``texts`` the device's frames did not say on the bus within the wait (with
    what they said instead)."""
    missing, heard, end = list(texts), [], time.monotonic() + HEARD_S
    while missing and time.monotonic() < end:
        message = emulated.host.recv(0.05)
        if message is not None and (frame := to_frame(message)) is not None:
            event = decoder.decode(frame, 0.0)
            heard.append(f"{frame.can_id:03X} {frame.data.hex()} {event.text}")
            if event.text in missing:
                missing.remove(event.text)
    return [*missing, f"(heard: {heard})"] if missing else []


def _drain(emulated: Emulated) -> None:
    while emulated.host.recv(0) is not None:
        pass


def _center(page: Any, selector: str) -> tuple[float, float]:
    """Where the element is in the window, scrolled into it first."""
    element = page.locator(selector)
    element.scroll_into_view_if_needed()
    box = element.bounding_box()
    return box["x"] + box["width"] / 2, box["y"] + box["height"] / 2


def _wait(page: Any, selector: str, condition: str) -> None:
    """Wait until ``condition`` (JavaScript on ``e``, the element) holds."""
    page.wait_for_function(f"() => {{ const e = document.querySelector('{selector}'); "
                           f"return e !== null && ({condition}); }}", timeout=WAIT_MS)


def _panel_cases() -> list[object]:
    """The panel's cases: every model, generation and protocol, in one quirk profile (the
    face, title and edition the page draws are the same in all of them: checked below)."""
    return [param for param, case in zip(cases("panel"), CASES, strict=True)
            if case.quirks == QUIRK_PROFILES[0]]


def test_the_face_is_the_same_in_every_quirk_profile() -> None:
    for case in CASES:
        drawn = case.description
        first = case.model.description(case.generation, QUIRK_PROFILES[0])
        assert (drawn.face, drawn.title, drawn.edition) == (first.face, first.title,
                                                            first.edition), str(case)


@pytest.mark.parametrize("case", _panel_cases())
def test_the_panel_draws_its_face_and_its_inputs_reach_the_twin(
        emulators: dict[str, Emulated], browser: Any, case: Case) -> None:
    emulated = emulators[str(case)]
    node = emulated.nodes[str(case)]
    page = _page(browser, emulated)
    device = f'[data-test="device-{node}"]'
    description = case.description
    face = description.face
    # its face, all of it and nothing else
    missing = [name for name, selector in _drawn(face).items()
               if page.locator(f"{device} {selector}").count() != 1]
    assert missing == [], f"not on the page: {missing}"
    counts = {prefix: page.locator(f'{device} [data-test^="{prefix}"]').count()
              for prefix in _COUNTED}
    assert counts == {prefix: count(face) for prefix, count in _COUNTED.items()}
    title = page.text_content(f"{device} h2")
    assert description.title in title
    assert description.edition in title
    if case.canopen:
        _wait(page, f'{device} [data-test="nmt-{node}"]', "e.textContent === 'operational'")
    decoder = Decoder({node: description})
    knobs = {encoder.key for encoder in face.encoders}
    plain = [key for key in face.key_numbers if key not in knobs]
    if plain:  # a key: pressed while the button is down, and said on the bus
        key = f'{device} [data-test="key-{plain[-1]}"]'
        _drain(emulated)
        page.mouse.move(*_center(page, key))
        page.mouse.down()
        _wait(page, key, "e.classList.contains('pressed')")
        page.mouse.up()
        _wait(page, key, "!e.classList.contains('pressed')")
        assert _heard(emulated, decoder, [f"key {plain[-1]} pressed",
                                          f"key {plain[-1]} released"]) == []
    for encoder in face.encoders[:1]:  # a knob: turned by the wheel, pushed by a click
        knob = f'{device} [data-test="key-{encoder.key}"]'
        before = _state(page, node)["encoders"][0]["counter"]
        page.mouse.move(*_center(page, knob))
        page.mouse.wheel(0, -100)  # up: one tick clockwise
        _wait(page, f'{knob} [data-test="counter-{encoder.number}"]',
              f"e.textContent === '{before + 1}'")
        _drain(emulated)
        page.click(knob)
        assert _heard(emulated, decoder, [f"key {encoder.key} pressed",
                                          f"key {encoder.key} released"]) == []
    if face.digital_inputs:  # a digital input: its switch flips its level
        number = face.digital_inputs - 1
        level = f'{device} [data-test="digital-{number}"]'
        _wait(page, level, "e.dataset.level !== undefined")
        before = page.get_attribute(level, "data-level")
        page.click(level)
        _wait(page, level, f"e.dataset.level !== '{before}'")
    if face.analog_inputs:  # an analog input: its slider sets the volts
        number, volts = 0, face.analog_volts_max / 2
        page.fill(f'{device} [data-test="analog-{number}"]', str(volts))
        page.dispatch_event(f'{device} [data-test="analog-{number}"]', "change")
        end = time.monotonic() + WAIT_MS / 1000
        while _state(page, node)["analog_inputs"][number]["volts"] != volts:
            assert time.monotonic() < end, "the slider did not reach the twin"
            time.sleep(0.05)
    for pin in face.pin_numbers[-1:]:  # an output: its fuse blows, its input goes high
        page.click(f'{device} [data-test="fuse-{pin}"]')
        _wait(page, f'{device} [data-test="fuse-{pin}"]', "e.textContent === 'replace fuse'")
        page.click(f'{device} [data-test="input-{pin}"]')
        _wait(page, f'{device} [data-test="input-{pin}"]', "e.textContent === 'input high'")
        pins = _state(page, node)["pins"][pin - 1]
        assert (pins["fuse"], pins["input"]) == ("blown", True)
