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
import time
from collections.abc import AsyncIterator, Callable, Collection
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
from blinkcan.devices.model import Face
from blinkcan.protocol.frame import Frame
from blinkcan.runtime import Emulator
from blinkcan.twin import KeyboxTwin
from blinkcan.twin.base import CanopenTwin
from blinkcan.web.guard import REQUEST_TIMEOUT_S, BodyError, Guard, json_body

MAX_UPDATES_PER_S = 30
FRAMES_KEPT = 20

#: action -> (the part of the face it acts on, what it does with (twin, value, now)); a device
#: has the action when its face has that part ("key": keys, "pin": pins; None: every device)
ACTIONS: dict[str, tuple[str | None, Callable[[Any, Any, float], object]]] = {
    "press": ("key", lambda t, v, now: t.press(v, now)),
    "release": ("key", lambda t, v, now: t.release(v, now)),
    "blow_fuse": ("pin", lambda t, v, now: t.blow_fuse(v, now)),
    "replace_fuse": ("pin", lambda t, v, now: t.replace_fuse(v, now)),
    "input_high": ("pin", lambda t, v, now: t.set_input(v, True, now)),
    "input_low": ("pin", lambda t, v, now: t.set_input(v, False, now)),
    "power_off": (None, lambda t, v, now: t.power_off()),
    "power_on": (None, lambda t, v, now: t.power_on(now)),
}
#: argument -> how many of it a model's face has
_COUNTS: dict[str, Callable[[Face], int]] = {"key": lambda f: f.keys, "pin": lambda f: f.pins}
_TICKS_PER_ACTION = 64  # a drag or scroll sends at most this many ticks at once

#: actions on what a face has besides keys and pins (knobs, inputs):
#: action -> (argument -> its valid range on a face, what it does with (twin, arguments, now))
FACE_ACTIONS: dict[str, tuple[dict[str, Callable[[Face], tuple[float, float]]],
                              Callable[[Any, dict[str, Any], float], object]]] = {
    "turn": ({"encoder": lambda f: (1, len(f.encoders)),
              "ticks": lambda f: (-_TICKS_PER_ACTION, _TICKS_PER_ACTION)},
             lambda t, a, now: t.turn(a["encoder"], a["ticks"], now)),
    "set_analog": ({"input": lambda f: (0, f.analog_inputs - 1),
                    "volts": lambda f: (0.0, f.analog_volts_max)},
                   lambda t, a, now: t.set_analog(a["input"], a["volts"], now)),
    "set_digital_input": ({"input": lambda f: (0, f.digital_inputs - 1),
                           "level": lambda f: (0, 1)},
                          lambda t, a, now: t.set_digital_input(a["input"], bool(a["level"]),
                                                                now)),
}


def _face_arguments(face: Face, action: str, request: dict[str, Any]) -> dict[str, Any]:
    """The arguments of a face action, each checked against the device's face."""
    ranges, _ = FACE_ACTIONS[action]
    arguments = {}
    for name, valid in ranges.items():
        low, high = valid(face)
        if high < low:
            raise ValueError(f"this device has nothing for {action!r}")
        value = request.get(name)
        number = (int, float) if isinstance(low, float) else (int,)
        if isinstance(value, bool) or not isinstance(value, number) or not low <= value <= high:
            raise ValueError(f"{name} must be {low}..{high}, not {value!r}")
        arguments[name] = value
    return arguments


class Panel:
    """Everything the page shows, gathered from the emulator."""

    def __init__(self, emulator: Emulator) -> None:
        self.emulator = emulator
        self.decoder = Decoder({t.node_id: t.description for t in emulator.twins})
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
        for twin, device in zip(self.emulator.twins, devices, strict=True):
            description = twin.description
            device["model"], device["title"] = description.model, description.title
            device["edition"] = description.edition
            device["face"] = self._faces.setdefault(description.model, asdict(description.face))
        return {"devices": devices, "frames": self.frames}

    def twin(self, node_id: object) -> CanopenTwin:
        for twin in self.emulator.twins:
            if twin.node_id == node_id:
                return twin
        nodes = ", ".join(f"{t.node_id}" for t in self.emulator.twins)
        raise ValueError(f"no device with node id {node_id!r}; the panel has {nodes}")

    def act(self, request: dict[str, Any]) -> None:
        """Validate and carry out one action (ValueError with the reason)."""
        if not isinstance(request, dict):
            raise ValueError("send a JSON object: {node, action, key|pin}")
        twin = self.twin(request.get("node"))
        action = request.get("action")
        if action in FACE_ACTIONS:
            arguments = _face_arguments(twin.description.face, action, request)
            perform_face = FACE_ACTIONS[action][1]
            self.emulator.run(lambda now: perform_face(twin, arguments, now))
            return
        if action not in ACTIONS:
            known = ", ".join([*ACTIONS, *FACE_ACTIONS])
            raise ValueError(f"unknown action {action!r}; known: {known}")
        argument, perform = ACTIONS[action]
        value = None
        if argument is not None:
            low, high = 1, _COUNTS[argument](twin.description.face)
            if high < low:
                raise ValueError(f"a {twin.description.title} has no action {action!r} "
                                 f"(it has no {argument}s)")
            value = request.get(argument)
            if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
                raise ValueError(f"{argument} must be {low}..{high}, not {value!r}")
        self.emulator.run(lambda now: perform(twin, value, now))


def create_app(emulator: Emulator, hosts: Collection[str] | None = ("127.0.0.1",),
               request_timeout: float = REQUEST_TIMEOUT_S) -> Starlette:
    """The panel's web app. ``hosts``: the Host names it answers to (None: any, for a wildcard
    address; see web/guard.py); ``request_timeout``: seconds a request body may take."""
    panel = Panel(emulator)
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
                text = json.dumps(await asyncio.to_thread(panel.state))
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
