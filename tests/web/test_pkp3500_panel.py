"""The PKP-3500-MT on the front panel, in a real browser: knobs turned by scrolling and dragging,
pushed by a click, ring LEDs drawn, analog inputs set by sliders; face actions validated."""

from __future__ import annotations

import time
import uuid
from collections.abc import Iterator

import can
import pytest

from blinkcan.protocol import Frame
from blinkcan.runtime import Emulator
from blinkcan.twin import KeypadTwin
from tests.host.conftest import wait_until
from tests.web.test_panel import CHROMIUM, Bench

playwright_api = pytest.importorskip("playwright.sync_api", reason="playwright is not installed")
pytest.importorskip("starlette", reason="the web extra is not installed")
from blinkcan.web.app import Panel  # noqa: E402
from blinkcan.web.server import PanelServer  # noqa: E402

pytestmark = pytest.mark.skipif(CHROMIUM is None, reason="Debian's chromium is not installed")


def quiet_mt() -> KeypadTwin:
    twin = KeypadTwin(node_id=0x15, model="pkp-3500-mt")
    twin.power_on(0.0)
    twin.receive(Frame(0x615, bytes.fromhex("2F14200000000000")), 0.0)  # no startup show
    twin.receive(Frame(0x615, bytes.fromhex("2F062000C8000000")), 0.0)  # 495h every 2 s
    twin.power_off()
    return twin


@pytest.fixture
def bench() -> Iterator[Bench]:
    channel = f"panel-mt-{uuid.uuid4().hex}"
    device_bus, host = (can.Bus(interface="virtual", channel=channel) for _ in range(2))
    keypad = quiet_mt()
    emulator = Emulator(device_bus, [keypad])
    with emulator, PanelServer(emulator, "127.0.0.1", 0) as server, \
            playwright_api.sync_playwright() as playwright:
        browser = playwright.chromium.launch(
            executable_path=CHROMIUM,
            args=["--no-sandbox", "--disable-gpu", "--disable-background-networking"])
        page = browser.new_page(viewport={"width": 1200, "height": 900})
        page.goto(server.url)
        page.wait_for_selector('[data-test="ring-led-1"]')
        bench = Bench(emulator, keypad, None, host, page)  # type: ignore[arg-type]
        bench.send("000 01 15")
        wait_until(lambda: emulator.snapshot(keypad)["nmt_state"] == "operational")
        yield bench
        browser.close()
    device_bus.shutdown()
    host.shutdown()


def test_the_knobs_turn_by_scrolling_and_dragging_and_push_by_a_click(bench: Bench) -> None:
    page = bench.page
    bench.received(0x295, timeout=0.1)
    page.hover('[data-test="key-1"]')  # type: ignore[attr-defined]
    page.mouse.wheel(0, -100)  # type: ignore[attr-defined]  # scroll up: one tick clockwise
    assert bench.received(0x295)[0].data[:4] == bytes.fromhex("01010008")
    box = page.locator('[data-test="key-11"]').bounding_box()  # type: ignore[attr-defined]
    x, y = box["x"] + box["width"] / 2, box["y"] + box["height"] / 2
    page.mouse.move(x, y)  # type: ignore[attr-defined]
    page.mouse.down()  # type: ignore[attr-defined]
    page.mouse.move(x, y - 40, steps=8)  # type: ignore[attr-defined]  # up 40 px: 3 ticks CW
    page.mouse.up()  # type: ignore[attr-defined]
    page.wait_for_function(  # type: ignore[attr-defined]
        """() => document.querySelector('[data-test="counter-2"]').textContent === '3'""")
    assert bench.emulator.snapshot(bench.keypad)["encoders"][1]["counter"] == 3
    bench.received(0x195, timeout=0.1)
    page.click('[data-test="key-1"]')  # type: ignore[attr-defined]  # a click pushes the knob
    assert [f.data[:2] for f in bench.received(0x195)[:2]] == [b"\x01\x00", b"\x00\x00"]


def test_ring_leds_and_analog_inputs(bench: Bench) -> None:
    page = bench.page
    bench.send("415 03 00 C0 00")  # ring LEDs 1, 2, 23, 24 (MT §17)
    page.wait_for_function(  # type: ignore[attr-defined]
        """() => ['1', '2', '23', '24'].every((n) => document.querySelector(
              `[data-test="ring-led-${n}"]`).classList.contains('lit'))
              && !document.querySelector('[data-test="ring-led-3"]').classList.contains('lit')""")
    page.fill('[data-test="analog-2"]', "3")  # type: ignore[attr-defined]
    page.dispatch_event('[data-test="analog-2"]', "change")  # type: ignore[attr-defined]
    wait_until(lambda: bench.emulator.snapshot(bench.keypad)["analog_inputs"][2]["volts"] == 3.0)


def test_face_actions_are_validated_against_the_face(bench: Bench) -> None:
    panel = Panel(bench.emulator)
    before = bench.emulator.snapshot(bench.keypad)
    for request in ({"node": 21, "action": "turn", "encoder": 3, "ticks": 1},
                    {"node": 21, "action": "turn", "encoder": 1, "ticks": 1000},
                    {"node": 21, "action": "turn", "encoder": 1, "ticks": 1.5},
                    {"node": 21, "action": "set_analog", "input": 4, "volts": 1.0},
                    {"node": 21, "action": "set_analog", "input": 0, "volts": 9.0},
                    {"node": 21, "action": "set_digital_input", "input": 0, "level": 2},
                    {"node": 21, "action": "press", "key": 16}):
        with pytest.raises(ValueError, match=r"must be|outside|has nothing"):
            panel.act(request)
    assert bench.emulator.snapshot(bench.keypad)["encoders"] == before["encoders"]
    panel.act({"node": 21, "action": "set_analog", "input": 1, "volts": 2.5})
    time.sleep(0.05)
    assert bench.emulator.snapshot(bench.keypad)["analog_inputs"][1]["digital"] is True
    state = panel.state()["devices"][0]
    assert list(state["face"]["grid"][0]) == [11, 6, 1]  # MT §2: key 1 top right
    assert state["title"] == "PKP-3500-MT keypad"


def test_the_title_names_the_model_and_its_manual(bench: Bench) -> None:
    title = bench.page.text_content('[data-test="device-21"] h2')  # type: ignore[attr-defined]
    assert title == "PKP-3500-MT keypad 15h · manual rev 1.3"
