"""Serve the front panel next to a running Emulator, in a thread of its own (uvicorn)."""

from __future__ import annotations

import logging
import threading
import time

import uvicorn

from blinkcan.runtime import Emulator
from blinkcan.web.app import create_app
from blinkcan.web.guard import (
    REQUEST_TIMEOUT_S,
    HeadTimeoutProtocol,
    allowed_hosts,
    exposure_warning,
)

DEFAULT_ADDRESS = "127.0.0.1:8080"


def parse_address(text: str) -> tuple[str, int]:
    """"HOST:PORT" (or ":PORT", or "PORT") -> (host, port); the host defaults to 127.0.0.1."""
    host, _, port = text.rpartition(":")
    try:
        number = int(port)
    except ValueError:
        raise ValueError(f"{text!r} is not HOST:PORT") from None
    if not 0 <= number <= 65535:
        raise ValueError(f"port {number} outside 0..65535")
    return host or "127.0.0.1", number


class PanelServer:
    """``with PanelServer(emulator, "127.0.0.1", 8080) as server: print(server.url)``.

    It answers only to its own address (web/guard.py); bound elsewhere than loopback it logs a
    warning (:attr:`warning`) that anyone on the network can reach it."""

    def __init__(self, emulator: Emulator, host: str = "127.0.0.1", port: int = 8080,
                 request_timeout: float = REQUEST_TIMEOUT_S) -> None:
        app = create_app(emulator, allowed_hosts(host), request_timeout)
        config = uvicorn.Config(app, host=host, port=port, log_level="warning", lifespan="off",
                                http=HeadTimeoutProtocol.with_timeout(request_timeout))
        self.warning = exposure_warning(host)
        self._server = uvicorn.Server(config)
        self._thread = threading.Thread(target=self._server.run, name="blinkcan-panel",
                                        daemon=True)
        self.host = host
        self.port = port

    @property
    def url(self) -> str:
        return f"http://{self.host}:{self.port}/"

    def start(self) -> PanelServer:
        if self.warning is not None:
            logging.getLogger(__name__).warning(self.warning)
        self._thread.start()
        deadline = time.monotonic() + 10
        while not self._server.started:
            if not self._thread.is_alive() or time.monotonic() > deadline:
                raise OSError(f"the panel could not listen on {self.host}:{self.port}")
            time.sleep(0.01)
        if self.port == 0:  # an ephemeral port: ask the socket which one
            self.port = self._server.servers[0].sockets[0].getsockname()[1]
        return self

    def stop(self) -> None:
        self._server.should_exit = True
        self._thread.join(timeout=5)

    def __enter__(self) -> PanelServer:
        return self.start()

    def __exit__(self, *exc_info: object) -> None:
        self.stop()
