"""Two devices with one node id on the front panel: ``blinkcan emulate keypad:0x15
keypad/j1939 --web`` (README: a CANopen and a J1939 keypad on one bus) runs a keypad in J1939
mode that keeps its CANopen node id 15h beside the CANopen keypad at 15h. The page keyed its
devices by node id: it drew one of the two (each state update redrew it as the other) and
every click went to the first; an API request naming node 21 acted on the first silently.
Now the page names each device by its place in the panel (``index``), and a node id two
devices share is refused, naming that."""

from __future__ import annotations

import uuid
from collections.abc import Iterator
from typing import Any

import can
import pytest

from blinkcan.runtime import Emulator
from blinkcan.twin import KeypadTwin
from tests.host.conftest import wait_until

pytest.importorskip("starlette", reason="the web extra is not installed")
from blinkcan.web.app import Panel
from blinkcan.web.server import PanelServer
from tests.web.test_panel import CHROMIUM

QUIET = {"startup_led_show": 0}


@pytest.fixture
def pair() -> Iterator[tuple[Emulator, KeypadTwin, KeypadTwin]]:
    """A CANopen keypad at 15h and a keypad in J1939 mode (address 21h, node id 15h)."""
    bus = can.Bus(interface="virtual", channel=f"panel-shared-{uuid.uuid4().hex}")
    canopen = KeypadTwin(node_id=0x15, settings=QUIET)
    j1939 = KeypadTwin(node_id=0x15, protocol="j1939", settings=QUIET)
    with Emulator(bus, [canopen, j1939]) as emulator:
        yield emulator, canopen, j1939
    bus.shutdown()


def test_the_api_names_each_device_by_its_index(
        pair: tuple[Emulator, KeypadTwin, KeypadTwin]) -> None:
    emulator, canopen, j1939 = pair
    panel = Panel(emulator)
    assert [(d["index"], d["protocol"]) for d in panel.state()["devices"]] == \
        [(0, "canopen"), (1, "j1939")]
    panel.act({"device": 1, "action": "press", "key": 3})
    wait_until(lambda: emulator.snapshot(j1939)["keys"][2]["pressed"])
    assert not emulator.snapshot(canopen)["keys"][2]["pressed"]
    with pytest.raises(ValueError, match="2 devices have node id 21: name one by its 'device'"):
        panel.act({"node": 21, "action": "press", "key": 4})
    for index in (2, -1, True, "1", None):
        with pytest.raises(ValueError, match=r"device must be an index 0\.\.1"):
            panel.act({"device": index, "action": "press", "key": 4})


@pytest.mark.skipif(CHROMIUM is None, reason="Debian's chromium is not installed")
def test_the_page_draws_both_and_a_click_reaches_the_one_clicked(
        pair: tuple[Emulator, KeypadTwin, KeypadTwin]) -> None:
    playwright_api: Any = pytest.importorskip("playwright.sync_api")
    emulator, canopen, j1939 = pair
    with PanelServer(emulator, "127.0.0.1", 0) as server, \
            playwright_api.sync_playwright() as playwright:
        browser = playwright.chromium.launch(
            executable_path=CHROMIUM,
            args=["--no-sandbox", "--disable-gpu", "--disable-background-networking"])
        page = browser.new_page(viewport={"width": 1500, "height": 1400})
        page.goto(server.url)
        page.wait_for_selector('[data-test="protocol-21"]')
        page.wait_for_timeout(500)  # a few updates: each redrew the one view as the other
        devices = page.query_selector_all('[data-test="device-21"]')
        assert len(devices) == 2
        assert "J1939" not in devices[0].inner_text()
        assert "J1939 21h" in devices[1].inner_text()
        key = devices[1].query_selector('[data-test="key-5"]')
        key.dispatch_event("pointerdown")
        wait_until(lambda: emulator.snapshot(j1939)["keys"][4]["pressed"])
        key.dispatch_event("pointerup")
        wait_until(lambda: not emulator.snapshot(j1939)["keys"][4]["pressed"])
        assert not emulator.snapshot(canopen)["keys"][4]["pressed"]
        browser.close()
