"""One SDO channel per node: one request at a time, a timeout and a bounded retry.

Real keypads drop an SDO request that arrives while they are still answering the previous one
(errata.md, field reports), so requests to one node are serialised here, whichever thread or
driver makes them.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import TYPE_CHECKING

from blinkcan.protocol.abort import AbortCode
from blinkcan.protocol.cob import SDO_RX, SDO_TX
from blinkcan.protocol.frame import Frame
from blinkcan.protocol.sdo_client import (
    DownloadTransfer,
    SdoError,
    SdoTimeoutError,
    UploadTransfer,
)

if TYPE_CHECKING:
    from blinkcan.host.bus import HostBus


class SdoChannel:
    """The client side of one node's SDO server."""

    def __init__(self, host: HostBus, node_id: int, timeout: float = 0.5, retries: int = 1
                 ) -> None:
        self.host = host
        self.node_id = node_id
        self.timeout = timeout
        self.retries = retries
        self._lock = threading.Lock()
        self._event = threading.Event()
        self._reply = b""
        self._request_id = SDO_RX + node_id
        host.subscribe_fast(SDO_TX + node_id, self._on_reply)

    def _on_reply(self, frame: Frame, now: float) -> None:
        self._reply = frame.data
        self._event.set()

    def upload(self, index: int, subindex: int) -> bytes:
        transfer = self._run(lambda: UploadTransfer(index, subindex))
        assert isinstance(transfer, UploadTransfer)
        return transfer.value

    def download(self, index: int, subindex: int, data: bytes) -> None:
        self._run(lambda: DownloadTransfer(index, subindex, data))

    def _run(self, make: Callable[[], UploadTransfer | DownloadTransfer]
             ) -> UploadTransfer | DownloadTransfer:
        """Run a fresh transfer per attempt; a timeout is retried, anything else raised."""
        if self.host.on_own_thread:
            raise RuntimeError("SDO transfers block: call them from your thread, not a handler")
        with self._lock:
            for attempt in range(self.retries + 1):
                transfer = make()
                try:
                    self._transfer(transfer)
                    return transfer
                except SdoTimeoutError:
                    abort = transfer.abort_request(AbortCode.SDO_PROTOCOL_TIMED_OUT)
                    self.host.send(Frame(self._request_id, abort))
                    if attempt == self.retries:
                        raise
                except SdoError as error:
                    if error.node_id is None:
                        error.node_id = self.node_id
                        error.args = (f"node {self.node_id:02X}h {error.args[0]}",)
                    raise
            raise AssertionError("unreachable")

    def _transfer(self, transfer: UploadTransfer | DownloadTransfer) -> None:
        request: bytes | None = transfer.start()
        while request is not None:
            self._event.clear()
            self.host.send(Frame(self._request_id, request))
            if not self._event.wait(self.timeout):
                raise SdoTimeoutError(f"no reply within {self.timeout} s", self.node_id,
                                      transfer.index, transfer.subindex)
            request = transfer.on_reply(self._reply)

