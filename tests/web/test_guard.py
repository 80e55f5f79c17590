"""The panel refuses what other web pages and other machines send (web/guard.py): foreign
origins, form bodies, other Host names, deep nesting, requests that never finish."""

from __future__ import annotations

import logging
import socket
import time
import uuid
import warnings
from collections.abc import Iterator

import can
import pytest

pytest.importorskip("starlette", reason="the web extra is not installed")
pytest.importorskip("httpx2", reason="httpx2 (the dev extra) is not installed")
with warnings.catch_warnings():
    # starlette's test client on the old httpx warns that it is deprecated: the dev extra
    # installs httpx2, which it takes first; a warning here means that is no longer so
    warnings.simplefilter("error")
    from starlette.testclient import TestClient

from blinkcan.runtime import Emulator
from blinkcan.twin import KeyboxTwin, KeypadTwin
from blinkcan.web.app import create_app
from blinkcan.web.guard import allowed_hosts, exposure_warning
from blinkcan.web.server import PanelServer

PRESS = {"node": 0x15, "action": "press", "key": 4}


@pytest.fixture
def emulator() -> Iterator[Emulator]:
    bus = can.Bus(interface="virtual", channel=f"guard-{uuid.uuid4().hex}")
    with Emulator(bus, [KeypadTwin(), KeyboxTwin()]) as running:
        yield running
    bus.shutdown()


@pytest.fixture
def client(emulator: Emulator) -> Iterator[TestClient]:
    with TestClient(create_app(emulator, hosts={"testserver"}),
                    base_url="http://testserver") as test_client:
        yield test_client


def _key_4_held(emulator: Emulator) -> bool:
    keypad = emulator.twins[0]
    return bool(emulator.snapshot(keypad)["keys"][3]["pressed"])


def test_the_panels_own_page_may_act(client: TestClient, emulator: Emulator) -> None:
    response = client.post("/api/action", json=PRESS,
                           headers={"Origin": "http://testserver", "Sec-Fetch-Site": "same-origin"})
    assert response.status_code == 200, response.text
    assert _key_4_held(emulator)


def test_a_form_from_another_site_is_refused(client: TestClient, emulator: Emulator) -> None:
    # what an HTML form on any web page can send: text/plain, cross-origin
    response = client.post("/api/action", content=b'{"node": 21, "action": "press", "key": 4}',
                           headers={"Content-Type": "text/plain", "Origin": "http://evil.test",
                                    "Sec-Fetch-Site": "cross-site"})
    assert response.status_code == 403
    assert not _key_4_held(emulator)


@pytest.mark.parametrize(("headers", "status"), [
    ({"Content-Type": "text/plain"}, 415),
    ({"Content-Type": "application/x-www-form-urlencoded"}, 415),
    ({"Content-Type": "application/json", "Origin": "http://evil.test"}, 403),
    ({"Content-Type": "application/json", "Sec-Fetch-Site": "same-site"}, 403),
    ({"Content-Type": "application/json", "Origin": "http://testserver:9999"}, 403),
])
def test_non_json_bodies_and_foreign_origins_are_refused(client: TestClient, emulator: Emulator,
                                                         headers: dict[str, str],
                                                         status: int) -> None:
    response = client.post("/api/action", content=b'{"node": 21, "action": "press", "key": 4}',
                           headers=headers)
    assert response.status_code == status
    assert not _key_4_held(emulator)


def test_a_foreign_host_name_is_refused_dns_rebinding(client: TestClient) -> None:
    assert client.get("/api/state", headers={"Host": "rebind.evil.test"}).status_code == 400
    assert client.post("/api/action", json=PRESS,
                       headers={"Host": "rebind.evil.test:8080"}).status_code == 400
    assert client.get("/api/state").status_code == 200


def test_deeply_nested_json_is_a_400_not_a_500(client: TestClient) -> None:
    body = b"[" * 100_000 + b"]" * 100_000
    response = client.post("/api/action", content=body[:16_000],
                           headers={"Content-Type": "application/json"})
    assert response.status_code == 400
    deep = b"[" * 5_000 + b"]" * 5_000
    response = client.post("/api/action", content=deep,
                           headers={"Content-Type": "application/json"})
    assert response.status_code == 400
    assert "Traceback" not in response.text


def test_a_body_over_the_limit_is_refused(client: TestClient) -> None:
    response = client.post("/api/action", content=b" " * 100_000,
                           headers={"Content-Type": "application/json"})
    assert response.status_code == 413


def test_the_hosts_a_bound_address_answers_to() -> None:
    assert allowed_hosts("127.0.0.1") >= {"127.0.0.1", "localhost", "[::1]"}  # type: ignore[operator]
    assert allowed_hosts("192.0.2.7") == frozenset({"192.0.2.7"})
    assert allowed_hosts("0.0.0.0") is None
    assert exposure_warning("127.0.0.1") is None
    warning = exposure_warning("0.0.0.0")
    assert warning is not None
    assert "reachable by anyone" in warning


def test_a_wildcard_panel_warns(emulator: Emulator, caplog: pytest.LogCaptureFixture) -> None:
    caplog.set_level(logging.WARNING)
    server = PanelServer(emulator, "0.0.0.0", 0)
    assert server.warning is not None
    assert "reachable by anyone" in server.warning
    quiet = PanelServer(emulator, "127.0.0.1", 0)
    assert quiet.warning is None


def _closed_within(sock: socket.socket, seconds: float) -> bool:
    sock.settimeout(seconds)
    try:
        while sock.recv(4096):
            pass  # a response (408) may come first; then the close
    except TimeoutError:
        return False
    except ConnectionError:
        return True
    return True


@pytest.mark.parametrize("partial", [
    b"GET /api/state HTTP/1.1\r\nHost: 127.0.0.1\r\n",  # a head that never ends
    b"POST /api/action HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: application/json\r\n"
    b"Content-Length: 100\r\n\r\n{",  # a body that never ends
    b"",  # a connection that never says anything
])
def test_requests_that_never_finish_are_closed(emulator: Emulator, partial: bytes) -> None:
    with PanelServer(emulator, "127.0.0.1", 0, request_timeout=0.5) as server, \
            socket.create_connection(("127.0.0.1", server.port)) as sock:
        sock.sendall(partial)
        started = time.monotonic()
        assert _closed_within(sock, 3.0)
        assert time.monotonic() - started < 3.0
