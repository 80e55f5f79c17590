"""Front panel: the time from a host's LED command on the bus to the browser showing it
(Playwright driving Debian's Chromium, the emulator and the panel on a virtual bus). Target:
< 300 ms (the panel pushes changes as server-sent events, at most MAX_UPDATES_PER_S a second).
Skipped, saying why, without playwright, the web extra or chromium."""

from __future__ import annotations

import importlib.util
import shutil
import statistics
import time
import uuid

import can

from blinkcan.protocol import Frame
from blinkcan.runtime import Emulator, to_message
from blinkcan.twin import KeypadTwin

SHOWN = """(phases) => document.querySelector('[data-test="key-3"]').dataset.phases === phases"""


def _quiet_keypad() -> KeypadTwin:
    """A keypad whose stored startup show is off, so its LEDs show only what is commanded."""
    twin = KeypadTwin()
    twin.power_on(0.0)
    twin.receive(Frame(0x615, bytes.fromhex("2F14200000000000")), 0.0)
    twin.power_off()
    return twin


def main(smoke: bool = False) -> None:
    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    absent = [name for name in ("playwright", "starlette")
              if importlib.util.find_spec(name) is None]
    if absent or chromium is None:
        print(f"panel latency: skipped ({', '.join(absent) or 'chromium'} not installed)")
        return
    from playwright.sync_api import sync_playwright

    from blinkcan.web.server import PanelServer

    channel = f"bench-panel-{uuid.uuid4().hex}"
    device_bus, host = (can.Bus(interface="virtual", channel=channel) for _ in range(2))
    emulator = Emulator(device_bus, [_quiet_keypad()])
    latencies = []
    try:
        with emulator, PanelServer(emulator, "127.0.0.1", 0) as server, \
                sync_playwright() as playwright:
            browser = playwright.chromium.launch(executable_path=chromium,
                                                 args=["--no-sandbox", "--disable-gpu"])
            page = browser.new_page()
            page.goto(server.url)
            page.wait_for_selector('[data-test="key-3"]')
            host.send(to_message(Frame(0, b"\x01\x15")))
            for n in range(4 if smoke else 20):
                red = n % 2 == 0
                started = time.monotonic()
                host.send(to_message(Frame(0x215, bytes([4 if red else 0]) + bytes(7))))
                page.wait_for_function(SHOWN, arg="red,red" if red else "off,off",
                                       timeout=5000, polling="raf")
                latencies.append(time.monotonic() - started)
            browser.close()
    finally:
        device_bus.shutdown()
        host.shutdown()
    median, worst = statistics.median(latencies) * 1000, max(latencies) * 1000
    print(f"panel latency: LED command to the browser showing it {median:.0f} ms median, "
          f"{worst:.0f} ms max over {len(latencies)} (target < 300 ms)")
