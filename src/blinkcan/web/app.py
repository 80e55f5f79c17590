"""The front panel's HTTP side: the page, the devices' state pushed as server-sent events, and
the actions a person can take (press a key, blow a fuse, power-cycle).

State comes from the twins' ``snapshot()`` on the emulator's thread, at most 30 times a
second, and only goes out when it changed, so the panel never slows the emulation. Actions go
through the same physical-side methods tests use. Every request is validated: a key or pin the
device's model has (its description's face), a known action for that device; anything else is a
400 with the reason. Each device's face (key grid, pins) goes to the page with its state.
"""

from __future__ import annotations

import asyncio
import json
import math
import time
from collections.abc import AsyncIterator, Collection
from dataclasses import asdict
from importlib import resources
from typing import Any

from starlette.applications import Starlette
from starlette.middleware import Middleware
from starlette.requests import Request
from starlette.responses import FileResponse, JSONResponse, Response, StreamingResponse
from starlette.routing import Mount, Route
from starlette.staticfiles import StaticFiles

from blinkcan.decode import Decoder
from blinkcan.decode.eventlog import EventLog
from blinkcan.protocol.frame import Frame
from blinkcan.runtime import Emulator
from blinkcan.twin import KeyboxTwin, KeypadTwin
from blinkcan.twin.actions import ACTIONS, actions_of
from blinkcan.twin.base import CanopenTwin
from blinkcan.web.guard import REQUEST_TIMEOUT_S, BodyError, Guard, json_body

MAX_UPDATES_PER_S = 30
FRAMES_KEPT = 20

class Panel:
    """Everything the page shows, gathered from the emulator."""

    def __init__(self, emulator: Emulator) -> None:
        self.emulator = emulator
        self.decoder = Decoder({t.node_id: t.description for t in emulator.twins})
        # a J1939 keypad's frames name its address, not its node id (spec J-1)
        self.decoder.j1939.addresses.update(
            t.j1939.address for t in emulator.twins
            if isinstance(t, KeypadTwin) and t.protocol == "j1939")
        #: the last frames with their meaning, repeated heartbeats and periodic frames folded
        #: (decode/eventlog.py)
        self.log = EventLog(FRAMES_KEPT, self.decoder)
        self._faces: dict[str, dict[str, Any]] = {}
        previous = emulator.on_frame

        def record(frame: Frame, sent: bool, now: float) -> None:
            if previous is not None:
                previous(frame, sent, now)
            self.log.add(self.decoder.decode(frame, now))

        emulator.on_frame = record

    @property
    def frames(self) -> list[dict[str, Any]]:
        """The last frames: seconds since the first, id, data, meaning (xN: folded)."""
        log = self.log
        return [{"time": f"{log.since_start(row.event):.3f}",
                 "id": f"{row.event.frame.can_id:03X}",
                 "data": row.event.frame.data.hex(" ").upper(), "text": row.text()}
                for row in list(log.rows)]

    def state(self) -> dict[str, Any]:
        devices = self.emulator.run(lambda now: [t.snapshot() for t in self.emulator.twins])
        for index, (twin, device) in enumerate(zip(self.emulator.twins, devices, strict=True)):
            description = twin.description
            device["index"] = index  # what the page names it by (node ids may be shared)
            device["model"], device["title"] = description.model, description.title
            device["edition"] = description.edition
            device["face"] = self._faces.setdefault(description.model, asdict(description.face))
        return {"devices": devices, "frames": self.frames}

    def twin(self, node_id: object) -> CanopenTwin:
        """The device at ``node_id``; a node id two devices share (a keypad in J1939 mode
        keeps its CANopen node id beside a CANopen device at it) names neither."""
        found = [twin for twin in self.emulator.twins if twin.node_id == node_id]
        if len(found) == 1:
            return found[0]
        nodes = ", ".join(f"{t.node_id}" for t in self.emulator.twins)
        if found:
            raise ValueError(f"{len(found)} devices have node id {node_id!r}: name one by its "
                             f"'device' index (0..{len(self.emulator.twins) - 1}, as "
                             "/api/state lists them)")
        raise ValueError(f"no device with node id {node_id!r}; the panel has {nodes}")

    def device(self, index: object) -> CanopenTwin:
        """The device at ``index`` in the panel's list (``/api/state``'s ``index``)."""
        twins = self.emulator.twins
        if isinstance(index, bool) or not isinstance(index, int) or \
                not 0 <= index < len(twins):
            raise ValueError(f"device must be an index 0..{len(twins) - 1}, not {index!r}")
        return twins[index]

    def act(self, request: dict[str, Any]) -> None:
        """Validate and carry out one action (ValueError with the reason): the actions and
        their arguments are the device's face's (twin/actions.py)."""
        if not isinstance(request, dict):
            raise ValueError("send a JSON object: {device (or node), action, key|pin|...}")
        twin = self.device(request["device"]) if "device" in request else \
            self.twin(request.get("node"))
        name = request.get("action")
        action = ACTIONS.get(name) if isinstance(name, str) else None
        if action is None:
            raise ValueError(f"unknown action {name!r}; known: {', '.join(ACTIONS)}")
        face = twin.description.face
        if not action.fits(face):
            raise ValueError(f"a {twin.description.title} has nothing for {name!r}; it has "
                             f"{', '.join(a.name for a in actions_of(face))}")
        arguments = action.check(face, request)
        self.emulator.run(lambda now: action.perform(twin, arguments, now))


class SharedState:
    """The panel's state as JSON text, gathered at most :data:`MAX_UPDATES_PER_S` times a
    second however many pages are open: every /api/events client reads the same text (one
    gathering per client made fifty open pages cost the emulator's thread 1,500 snapshots a
    second and delayed actions)."""

    def __init__(self, panel: Panel) -> None:
        self.panel = panel
        self._lock = asyncio.Lock()
        self._text = ""
        self._gathered = -math.inf

    async def text(self) -> str:
        async with self._lock:
            if time.monotonic() - self._gathered >= 1 / MAX_UPDATES_PER_S:
                self._text = json.dumps(await asyncio.to_thread(self.panel.state))
                self._gathered = time.monotonic()
            return self._text


def create_app(emulator: Emulator, hosts: Collection[str] | None = ("127.0.0.1",),
               request_timeout: float = REQUEST_TIMEOUT_S) -> Starlette:
    """The panel's web app. ``hosts``: the Host names it answers to (None: any, for a wildcard
    address; see web/guard.py); ``request_timeout``: seconds a request body may take."""
    panel = Panel(emulator)
    shared = SharedState(panel)
    static = resources.files("blinkcan.web") / "static"

    async def index(request: Request) -> Response:
        return FileResponse(str(static / "index.html"))

    async def state(request: Request) -> Response:
        return JSONResponse(await asyncio.to_thread(panel.state))

    async def events(request: Request) -> Response:
        async def stream() -> AsyncIterator[str]:
            last = ""
            while not await request.is_disconnected():
                started = time.monotonic()
                text = await shared.text()
                if text != last:
                    last = text
                    yield f"data: {text}\n\n"
                await asyncio.sleep(max(0.0, 1 / MAX_UPDATES_PER_S - (time.monotonic() - started)))

        return StreamingResponse(stream(), media_type="text/event-stream",
                                 headers={"Cache-Control": "no-store"})

    async def action(request: Request) -> Response:
        try:
            body = await json_body(request, request_timeout)
        except BodyError as error:  # an unread or slow body: do not wait for more of it
            return JSONResponse({"error": str(error)}, status_code=error.status,
                                headers={"Connection": "close"})
        try:
            await asyncio.to_thread(panel.act, body)
        except (ValueError, TypeError) as error:
            return JSONResponse({"error": str(error)}, status_code=400)
        return JSONResponse({"ok": True})

    return Starlette(routes=[
        Route("/", index),
        Route("/api/state", state),
        Route("/api/events", events),
        Route("/api/action", action, methods=["POST"]),
        Mount("/static", StaticFiles(directory=str(static)), name="static"),
    ], middleware=[Middleware(Guard, hosts=hosts)])


__all__ = ["ACTIONS", "KeyboxTwin", "Panel", "create_app"]
