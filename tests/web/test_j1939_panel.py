"""The front panel with a keypad in J1939 mode: protocol and source address shown, keys and
LEDs working over J1939 (Playwright and Debian's Chromium, as tests/web/test_panel.py)."""

from __future__ import annotations

import shutil
import time
import uuid
from collections.abc import Iterator
from typing import Any

import can
import pytest

from blinkcan.protocol import Frame
from blinkcan.runtime import Emulator, to_frame, to_message
from blinkcan.twin import KeypadTwin
from tests.host.conftest import wait_until

playwright_api = pytest.importorskip("playwright.sync_api", reason="playwright is not installed")
pytest.importorskip("starlette", reason="the web extra is not installed")
from blinkcan.web.server import PanelServer  # noqa: E402

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
pytestmark = pytest.mark.skipif(CHROMIUM is None,
                                reason="Debian's chromium is not installed (apt-get install "
                                       "chromium); .ci/run installs it")


@pytest.fixture
def bench() -> Iterator[tuple[Any, Emulator, KeypadTwin, can.BusABC]]:
    channel = f"panel-j1939-{uuid.uuid4().hex}"
    device_bus, host = (can.Bus(interface="virtual", channel=channel) for _ in range(2))
    twin = KeypadTwin(protocol="j1939")
    emulator = Emulator(device_bus, [twin])
    with emulator, PanelServer(emulator, "127.0.0.1", 0) as server, \
            playwright_api.sync_playwright() as playwright:
        browser = playwright.chromium.launch(
            executable_path=CHROMIUM,
            args=["--no-sandbox", "--disable-gpu", "--disable-background-networking"])
        page = browser.new_page(viewport={"width": 1500, "height": 900})
        page.goto(server.url)
        page.wait_for_selector('[data-test="key-1"]')
        yield page, emulator, twin, host
        browser.close()
    device_bus.shutdown()
    host.shutdown()


def test_the_panel_shows_j1939_mode_and_address(
        bench: tuple[Any, Emulator, KeypadTwin, can.BusABC]) -> None:
    page, emulator, twin, host = bench
    page.wait_for_selector('[data-test="protocol-21"]')
    assert "J1939 21h" in page.text_content('[data-test="device-21"] h2')
    assert page.text_content('[data-test="address-21"]') == "21h"
    host.send(to_message(Frame(0x18EF2100, bytes.fromhex("041B7030FFFFFFFF"), extended=True)))
    page.wait_for_function(
        "document.querySelector('[data-test=\"address-21\"]').textContent === '30h'")
    page.click('[data-test="key-4"]')
    frames: list[Frame] = []
    end = time.monotonic() + 2
    while time.monotonic() < end and len(frames) < 2:
        message = host.recv(0.05)
        if message is not None and (frame := to_frame(message)) is not None:
            frames.append(frame)
    assert [f.data.hex() for f in frames] == ["041b010401" + "21ffff", "041b010400" + "21ffff"]
    assert {f.can_id for f in frames} == {0x18EFFF30}
    wait_until(lambda: not emulator.snapshot(twin)["keys"][3]["pressed"])


def test_the_panel_shows_amber_and_yellow_green_as_commanded(
        bench: tuple[Any, Emulator, KeypadTwin, can.BusABC]) -> None:
    """Issue 20 item 4: §7a 08h amber and 09h yellow/green are not the yellow of 04h."""
    page, emulator, twin, host = bench
    host.send(to_message(Frame(0x18EF2100, bytes.fromhex("041B0104040100FF"), extended=True)))
    host.send(to_message(Frame(0x18EF2100, bytes.fromhex("041B0105080100FF"), extended=True)))
    host.send(to_message(Frame(0x18EF2100, bytes.fromhex("041B0106090100FF"), extended=True)))
    wait_until(lambda: emulator.snapshot(twin)["commanded"][5]["colour"] == "yellow/green")
    page.wait_for_function(  # once the startup show is over
        "document.querySelector('[data-test=\"key-6\"]').dataset.phases === "
        "'yellow/green,yellow/green'", timeout=10_000)
    colours = [page.get_attribute(f'[data-test="key-{key}"]', "data-phases")
               for key in (4, 5, 6)]
    assert colours == ["yellow,yellow", "amber,amber", "yellow/green,yellow/green"]
