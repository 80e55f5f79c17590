"""The front panel in a real browser: Playwright driving Debian's Chromium, the emulator and
the panel on a virtual bus, a host on the same bus."""

from __future__ import annotations

import shutil
import time
import uuid
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import can
import pytest

from blinkcan.protocol import Frame
from blinkcan.runtime import Emulator, to_frame, to_message
from blinkcan.twin import KeyboxTwin, KeypadTwin
from tests.host.conftest import quiet_keypad, wait_until

playwright_api = pytest.importorskip("playwright.sync_api", reason="playwright is not installed")
pytest.importorskip("starlette", reason="the web extra is not installed")
from blinkcan.web.server import PanelServer  # noqa: E402

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
pytestmark = pytest.mark.skipif(CHROMIUM is None,
                                reason="Debian's chromium is not installed (apt-get install "
                                       "chromium); .ci/run installs it")
SCREENSHOT = Path(__file__).resolve().parents[2] / ".artifacts" / "panel.png"  # for a person


@dataclass
class Bench:
    emulator: Emulator
    keypad: KeypadTwin
    keybox: KeyboxTwin
    host: can.BusABC
    page: object

    def send(self, text: str) -> None:
        ident, *data = text.split()
        self.host.send(to_message(Frame(int(ident, 16), bytes(int(b, 16) for b in data))))

    def received(self, can_id: int, timeout: float = 2.0, quiet: float = 0.5) -> list[Frame]:
        """The frames of ``can_id`` heard until ``quiet`` seconds pass without one after the
        first (a loaded machine spaces a click's press and release), or ``timeout``."""
        frames, end = [], time.monotonic() + timeout
        last = 0.0
        while time.monotonic() < end:
            message = self.host.recv(0.05)
            if message is not None and (frame := to_frame(message)) is not None \
                    and frame.can_id == can_id:
                frames.append(frame)
                last = time.monotonic()
            elif frames and time.monotonic() - last > quiet:
                break
        return frames


@pytest.fixture
def bench() -> Iterator[Bench]:
    channel = f"panel-{uuid.uuid4().hex}"
    device_bus, host = (can.Bus(interface="virtual", channel=channel) for _ in range(2))
    keypad, keybox = quiet_keypad(), KeyboxTwin(low_side=(2,))
    second = quiet_keypad(node_id=0x16, manual="1.5")  # issue 7: the panel names generations
    emulator = Emulator(device_bus, [keypad, keybox, second])
    with emulator, PanelServer(emulator, "127.0.0.1", 0) as server, \
            playwright_api.sync_playwright() as playwright:
        browser = playwright.chromium.launch(
            executable_path=CHROMIUM,
            args=["--no-sandbox", "--disable-gpu", "--disable-background-networking"])
        page = browser.new_page(viewport={"width": 1500, "height": 900})
        page.goto(server.url)
        page.wait_for_selector('[data-test="key-1"]')
        bench = Bench(emulator, keypad, keybox, host, page)
        bench.send("000 01 00")  # start them all, and wait until they are
        wait_until(lambda: all(emulator.snapshot(t)["nmt_state"] == "operational"
                               for t in emulator.twins))
        yield bench
        browser.close()
    device_bus.shutdown()
    host.shutdown()


def colour(page: object, key: int) -> str:
    return str(page.get_attribute(f'[data-test="key-{key}"]', "data-phases"))  # type: ignore[attr-defined]


def test_the_page_shows_what_the_host_lights_with_no_reload(bench: Bench) -> None:
    """The panel pushes what changed (how fast: benchmarks/panel_latency.py)."""
    page = bench.page
    bench.send("215 04 00 00 00 00 00 00 00")  # key 3 red
    bench.send("315 00 00 04 00 00 00 00 00")  # key 7 green blinking (byte 2: G12..G5)
    page.wait_for_function(  # type: ignore[attr-defined]
        """() => document.querySelector('[data-test="key-3"]').dataset.phases === 'red,red'
              && document.querySelector('[data-test="key-7"]').dataset.phases === 'off,green'""",
        timeout=10000)


def test_clicking_a_key_sends_press_and_release(bench: Bench) -> None:
    time.sleep(0.2)
    bench.received(0x195, timeout=0.1)
    bench.page.click('[data-test="key-5"]')  # type: ignore[attr-defined]
    frames = bench.received(0x195)
    assert [f.data[:2] for f in frames[:2]] == [b"\x10\x00", b"\x00\x00"]


def test_outputs_and_a_blown_fuse(bench: Bench) -> None:
    page = bench.page
    bench.send("20C 00 00 08 00 00 00 00 00")  # output 4 HIGH
    page.wait_for_function(  # type: ignore[attr-defined]
        """() => document.querySelector('[data-test="state-4"]').textContent === 'HIGH'""")
    bench.received(0x18C, timeout=0.1)
    page.click('[data-test="fuse-4"]')  # type: ignore[attr-defined]
    assert bench.received(0x18C)[0].data[:2] == b"\x08\x00"
    page.wait_for_function(  # type: ignore[attr-defined]
        """() => document.querySelector('[data-test="state-4"]').textContent === 'FAULT'""")
    SCREENSHOT.parent.mkdir(exist_ok=True)
    bench.send("215 42 00 01 00 00 00 00 00")
    bench.send("515 20 00 00 00 00 00 00 00")
    time.sleep(0.3)
    page.screenshot(path=str(SCREENSHOT))  # type: ignore[attr-defined]


def test_power_off_and_on_from_the_page(bench: Bench) -> None:
    page = bench.page
    page.click('[data-test="power-21"]')  # type: ignore[attr-defined]
    page.wait_for_function(  # type: ignore[attr-defined]
        """() => document.querySelector('[data-test="nmt-21"]').textContent === 'off'""")
    bench.received(0x715, timeout=0.1)
    page.click('[data-test="power-21"]')  # type: ignore[attr-defined]
    assert bench.received(0x715)[0].data == b"\x00"


def test_the_panel_shows_each_keypads_generation(bench: Bench) -> None:
    page = bench.page
    first = page.text_content('[data-test="device-21"] h2')  # type: ignore[attr-defined]
    second = page.text_content('[data-test="device-22"] h2')  # type: ignore[attr-defined]
    assert "generation 1 (manual rev 1.1)" in first
    assert "generation 2 (manual rev 1.5)" in second


def test_bad_requests_are_refused_and_change_nothing(bench: Bench) -> None:
    page = bench.page
    before = bench.emulator.snapshot(bench.keybox)
    for body in ('{"node": 21, "action": "press", "key": 13}',
                 '{"node": 12, "action": "blow_fuse", "pin": 0}',
                 '{"node": 12, "action": "press", "key": 1}',
                 '{"node": 99, "action": "power_off"}',
                 '{"node": 21, "action": "format_disk"}',
                 'not json'):
        status = page.evaluate(  # type: ignore[attr-defined]
            "async (body) => (await fetch('/api/action', {method: 'POST', body,"
            " headers: {'Content-Type': 'application/json'}})).status", body)
        assert status == 400, body
    plain = page.evaluate(  # type: ignore[attr-defined]  # what an HTML form can send
        "async () => (await fetch('/api/action', {method: 'POST',"
        " body: '{\"node\": 12, \"action\": \"blow_fuse\", \"pin\": 4}'})).status")
    assert plain == 415
    assert bench.emulator.snapshot(bench.keybox) == before


def test_indicator_brightness_0_is_drawn_dark(bench: Bench) -> None:
    page = bench.page
    bench.send("215 01 00 00 00 00 00 00 00")  # key 1 red
    bench.send("415 00 00 00 00 00 00 00 00")  # indicator brightness 0 (PKP §13)
    page.wait_for_function(  # type: ignore[attr-defined]
        """() => { const key = document.querySelector('[data-test="key-1"]');
                   return key.dataset.colour === 'red' && key.dataset.shown === 'off'; }""",
        timeout=3000)
    bench.send("415 3F 00 00 00 00 00 00 00")  # full brightness: red again
    page.wait_for_function(  # type: ignore[attr-defined]
        """() => document.querySelector('[data-test="key-1"]').dataset.shown === 'red'""",
        timeout=3000)
