"""What keeps other web pages and other machines away from the panel.

The panel presses keys and blows fuses, so a request must come from the panel's own page:

- ``Host`` must name the address the panel is bound to (127.0.0.1 also answers to localhost and
  [::1]); any other name is a DNS-rebinding page and gets a 400. Bound to a wildcard address
  (0.0.0.0, ::) every name is served, and :func:`exposure_warning` says so.
- A state-changing request (POST) that carries ``Origin`` must be same-origin, and one that
  carries ``Sec-Fetch-Site`` must say ``same-origin`` (or ``none``): 403 otherwise. A form on
  another site cannot send JSON, so the action endpoint also refuses any body that is not
  ``application/json`` (415), longer than :data:`MAX_BODY_BYTES` (413) or too deeply nested
  (400).
- A request head or body that never finishes is closed after :data:`REQUEST_TIMEOUT_S`
  (:class:`HeadTimeoutProtocol` for the head, which uvicorn would wait for forever; the action
  endpoint for the body).
"""

from __future__ import annotations

import asyncio
import ipaddress
import json
from collections.abc import Collection
from typing import Any

from starlette.datastructures import Headers
from starlette.requests import Request
from starlette.responses import JSONResponse
from starlette.types import ASGIApp, Receive, Scope, Send
from uvicorn.protocols.http.h11_impl import H11Protocol

from blinkcan.errors import BlinkcanError

REQUEST_TIMEOUT_S = 10.0
MAX_BODY_BYTES = 16 * 1024
_LOOPBACK_NAMES = frozenset({"localhost", "127.0.0.1", "[::1]", "::1"})


def _is_wildcard(host: str) -> bool:
    return host in ("", "0.0.0.0", "::", "[::]")


def _is_loopback(host: str) -> bool:
    if host in _LOOPBACK_NAMES:
        return True
    try:
        return ipaddress.ip_address(host.strip("[]")).is_loopback
    except ValueError:
        return False


def allowed_hosts(bound: str) -> frozenset[str] | None:
    """Host names a request may use for a panel bound to ``bound``; None: any (wildcard)."""
    if _is_wildcard(bound):
        return None
    names = {bound.lower(), f"[{bound}]" if ":" in bound and not bound.startswith("[") else bound}
    if _is_loopback(bound):
        names |= _LOOPBACK_NAMES
    return frozenset(names)


def exposure_warning(bound: str) -> str | None:
    """The warning a panel bound to ``bound`` deserves, or None."""
    if _is_loopback(bound):
        return None
    reach = "anyone who can reach this machine" if _is_wildcard(bound) else \
        f"anyone who can reach {bound}"
    return (f"the panel on {bound or '0.0.0.0'} is reachable by {reach} on the network: they can"
            " press keys, blow fuses and power the devices off; bind 127.0.0.1 unless you mean it")


def _hostname(host_header: str) -> str:
    """``"localhost:8080"`` -> ``"localhost"``, ``"[::1]:80"`` -> ``"[::1]"``."""
    host = host_header.strip().lower()
    if host.startswith("["):
        return host[: host.find("]") + 1] if "]" in host else host
    return host.rsplit(":", 1)[0] if host.count(":") == 1 else host


class Guard:
    """ASGI middleware: the Host, Origin and Sec-Fetch-Site rules of the module docstring."""

    def __init__(self, app: ASGIApp, hosts: Collection[str] | None) -> None:
        self.app = app
        self.hosts = None if hosts is None else frozenset(h.lower() for h in hosts)

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        headers = Headers(scope=scope)
        host = headers.get("host", "")
        refusal: tuple[int, str] | None = None
        if self.hosts is not None and _hostname(host) not in self.hosts:
            refusal = (400, f"Host {host!r} is not this panel's address")
        elif scope["method"] not in ("GET", "HEAD", "OPTIONS"):
            origin = headers.get("origin")
            site = headers.get("sec-fetch-site")
            if origin is not None and origin.lower() != f"{scope.get('scheme', 'http')}://{host}":
                refusal = (403, f"requests from {origin} are refused: use the panel's own page")
            elif site is not None and site not in ("same-origin", "none"):
                refusal = (403, f"{site} requests are refused: use the panel's own page")
        if refusal is not None:
            status, reason = refusal
            await JSONResponse({"error": reason}, status_code=status)(scope, receive, send)
            return
        await self.app(scope, receive, send)


class BodyError(BlinkcanError, ValueError):
    """A request body the panel refuses; ``status`` is the HTTP status to answer with."""

    def __init__(self, status: int, reason: str) -> None:
        super().__init__(reason)
        self.status = status


async def json_body(request: Request, timeout: float = REQUEST_TIMEOUT_S) -> Any:
    """The request's JSON document, or :class:`BodyError` (415, 413, 408, 400)."""
    kind = request.headers.get("content-type", "").split(";")[0].strip().lower()
    if kind != "application/json":
        raise BodyError(415, f"send application/json, not {kind or 'no content type'}")
    chunks: list[bytes] = []
    size = 0

    async def read() -> None:
        nonlocal size
        async for chunk in request.stream():
            size += len(chunk)
            if size > MAX_BODY_BYTES:
                raise BodyError(413, f"the body is over {MAX_BODY_BYTES} bytes")
            chunks.append(chunk)

    try:
        await asyncio.wait_for(read(), timeout)
    except asyncio.TimeoutError:
        raise BodyError(408, f"the body did not arrive within {timeout:g} s") from None
    try:
        return json.loads(b"".join(chunks))
    except RecursionError:
        raise BodyError(400, "the JSON is nested too deeply") from None
    except ValueError:
        raise BodyError(400, "the body is not JSON") from None


class HeadTimeoutProtocol(H11Protocol):
    """uvicorn's h11 protocol with a deadline for each request head: a client that opens a
    connection, or starts a request, and never finishes its head is disconnected after
    ``timeout`` seconds (uvicorn itself would keep the descriptor forever); :meth:`with_timeout`
    makes the class a server uses."""

    timeout = REQUEST_TIMEOUT_S
    _head_timer: asyncio.TimerHandle | None = None

    @classmethod
    def with_timeout(cls, timeout: float) -> type[HeadTimeoutProtocol]:
        return type("HeadTimeoutProtocol", (cls,), {"timeout": timeout})

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        super().connection_made(transport)  # type: ignore[arg-type]
        self._arm()

    def data_received(self, data: bytes) -> None:
        super().data_received(data)
        if not self._awaiting_head():
            self._disarm()
        elif self._head_timer is None:
            self._arm()

    def connection_lost(self, exc: Exception | None) -> None:
        self._disarm()
        super().connection_lost(exc)

    def _awaiting_head(self) -> bool:
        return self.cycle is None or self.cycle.response_complete

    def _arm(self) -> None:
        self._head_timer = self.loop.call_later(self.timeout, self._expire)

    def _disarm(self) -> None:
        if self._head_timer is not None:
            self._head_timer.cancel()
            self._head_timer = None

    def _expire(self) -> None:
        self._head_timer = None
        if self._awaiting_head() and not self.transport.is_closing():
            self.transport.close()
