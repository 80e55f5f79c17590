"""Many pages open on the panel (found by the attack pass of session 5): its state is gathered
at most MAX_UPDATES_PER_S times a second whatever the number of /api/events clients (each
gathered its own, 30 a second: fifty pages were 1,500 snapshots a second on the emulator's
thread); and a J1939 keypad's frames are shown with their meaning at any address."""

from __future__ import annotations

import socket
import time
import uuid
from collections.abc import Iterator

import can
import pytest

from blinkcan.runtime import Emulator
from blinkcan.twin import KeyboxTwin, KeypadTwin

pytest.importorskip("starlette", reason="the web extra is not installed")
from blinkcan.web import app
from blinkcan.web.server import PanelServer

CLIENTS = 40


@pytest.fixture
def device_bus() -> Iterator[can.BusABC]:
    bus = can.Bus(interface="virtual", channel=f"panel-clients-{uuid.uuid4().hex}")
    yield bus
    bus.shutdown()


def _first_event(connection: socket.socket) -> bytes:
    received = b""
    while b"\ndata: " not in received:
        chunk = connection.recv(65536)
        assert chunk, "the server closed the stream"
        received += chunk
    return received


def test_many_pages_share_one_gathering_of_the_state(device_bus: can.BusABC,
                                                     monkeypatch: pytest.MonkeyPatch) -> None:
    gathered: list[float] = []
    state = app.Panel.state

    def counted(panel: app.Panel) -> object:
        gathered.append(time.monotonic())
        return state(panel)

    monkeypatch.setattr(app.Panel, "state", counted)
    with Emulator(device_bus, [KeypadTwin(), KeyboxTwin()]) as emulator, \
            PanelServer(emulator, "127.0.0.1", 0) as server:
        connections = [socket.create_connection(("127.0.0.1", server.port), timeout=30)
                       for _ in range(CLIENTS)]
        try:
            started = time.monotonic()
            for connection in connections:
                connection.sendall(f"GET /api/events HTTP/1.1\r\nHost: 127.0.0.1:{server.port}"
                                   "\r\n\r\n".encode())
            for connection in connections:
                assert b'"devices"' in _first_event(connection)
            elapsed = time.monotonic() - started
            during = [t for t in gathered if t >= started]
        finally:
            for connection in connections:
                connection.close()
    assert during
    assert len(during) <= app.MAX_UPDATES_PER_S * elapsed + 2, (len(during), elapsed)


def test_a_j1939_keypad_frames_are_shown_with_their_meaning_at_any_address(
        device_bus: can.BusABC) -> None:
    twin = KeypadTwin(protocol="j1939", settings={"j1939_source_address": 0x30})
    with Emulator(device_bus, [twin]) as emulator:
        panel = app.Panel(emulator)
        emulator.run(lambda now: twin.press(3, now))
        deadline = time.monotonic() + 10
        while not panel.frames and time.monotonic() < deadline:
            time.sleep(0.01)
        texts = [row["text"] for row in panel.frames]
    assert "keypad 30h: key 3 pressed" in texts, texts
