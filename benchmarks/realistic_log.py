"""A realistic bus log for the decode benchmarks: the devices' own traffic plus other ECUs'.

One third is the devices' traffic, made by the twins: a CANopen twin of every registered model
(key presses, heartbeats, LED and output PDOs from the controller, SDO reads the twins answer)
and a keypad in J1939 mode (key messages, heartbeats, LED commands it acknowledges). One third
is other ECUs' 11-bit frames (proprietary identifiers, some periodic status frames that rarely
change, some sensor frames that change every time). One third is 29-bit J1939 engine and vehicle
frames (EEC1, EEC2, ETC1, CCVS, ET1, LFE, AMB, ... from the engine, transmission, brakes and
cluster), none addressed to the keypad. Seeded, so every run decodes the same bytes.
"""

from __future__ import annotations

import random
from pathlib import Path
from typing import Any

from blinkcan.devices.keypad_j1939 import COMMANDS, DEFAULT_HOST_ADDRESS, PRIORITY
from blinkcan.devices.pdo import PdoLayout
from blinkcan.devices.registry import models
from blinkcan.protocol import Frame
from blinkcan.protocol.cob import HEARTBEAT, NMT, SDO_RX
from blinkcan.protocol.j1939 import PGN_PROPRIETARY_A, compose_id
from blinkcan.twin import KeypadTwin
from blinkcan.twin.base import CanopenTwin
from blinkcan.twin.registry import build_twin

#: (priority, PGN) of common J1939 engine and vehicle messages (J1939-71)
ENGINE_PGNS = ((3, 0xF004), (3, 0xF003), (3, 0xF002), (6, 0xF001), (6, 0xFEF1), (6, 0xFEEE),
               (6, 0xFEEF), (6, 0xFEF2), (6, 0xFEF5), (6, 0xFEF6), (6, 0xFEF7), (6, 0xFEE5),
               (6, 0xFEE0), (6, 0xFEFC), (6, 0xFE6C), (6, 0xFEE9), (6, 0xFEF0), (6, 0xFD09))
#: engine, transmission, brakes, instrument cluster, body controller
ENGINE_SOURCES = (0x00, 0x03, 0x0B, 0x17, 0x31)
#: the J1939 keypad's address (§5 default) and the CANopen nodes of the devices
J1939_KEYPAD = 0x21


def device_nodes() -> dict[int, str]:
    """Every registered model at a node of its own: its default, or the next free one."""
    nodes: dict[int, str] = {}
    for found in models():
        node = found.default_node_id
        while node in nodes:
            node += 1
        nodes[node] = found.name
    return nodes


def device_options() -> list[str]:
    """``--device NODE=MODEL`` for every device of the log."""
    return [item for node, name in device_nodes().items()
            for item in ("--device", f"0x{node:02X}={name}")]


def _random_pdo(layout: PdoLayout, node: int, chance: random.Random) -> Frame:
    values = {s.name: chance.getrandbits(s.length) for s in layout.signals}
    return Frame(layout.cob_id(node), layout.encode(values))


class _Devices:
    """The devices' traffic: each call to :meth:`step` adds what happens next."""

    def __init__(self, chance: random.Random) -> None:
        self.chance = chance
        self.twins: list[CanopenTwin] = [build_twin(name, node_id=node)
                                         for node, name in device_nodes().items()]
        self.j1939 = KeypadTwin(protocol="j1939")
        self.log: list[tuple[float, Frame]] = []
        for twin in (*self.twins, self.j1939):
            self.log += [(0.0, f) for f in twin.power_on(0.0)]
        self._all(Frame(NMT, bytes((0x01, 0x00))), 0.0)
        by_name = {c.name: c for c in COMMANDS}
        self._heartbeat_on = by_name["heartbeat"].encode(1, 10)
        self._single_led = by_name["single_led"]
        self._host_id = compose_id(PGN_PROPRIETARY_A, DEFAULT_HOST_ADDRESS, J1939_KEYPAD,
                                   PRIORITY)
        self._j1939(self._heartbeat_on, 0.0)
        self._j1939(by_name["led_acknowledge"].encode(1), 0.0)
        self.pdos = [(layout, twin.node_id) for twin in self.twins
                     for layout in twin.description.pdos]
        self.readable = [(twin, entry) for twin in self.twins for entry in twin.description.table
                         if entry.access.readable and not entry.data_type.is_string]
        self.keypads: list[Any] = [twin for twin in self.twins if hasattr(twin, "press")]
        self.held: dict[int, int] = {}

    def _all(self, frame: Frame, now: float) -> None:
        self.log.append((now, frame))
        for twin in self.twins:
            self.log += [(now, f) for f in twin.receive(frame, now)]

    def _j1939(self, data: bytes, now: float) -> None:
        frame = Frame(self._host_id, data, True)
        self.log.append((now, frame))
        self.log += [(now, f) for f in self.j1939.receive(frame, now)]

    def step(self, now: float) -> None:
        chance = self.chance
        for twin in (*self.twins, self.j1939):
            self.log += [(now, f) for f in twin.advance(now)]
        roll = chance.random()
        if roll < 0.25:  # a key pressed or released on a CANopen keypad
            twin = chance.choice(self.keypads)
            key = self.held.pop(id(twin), 0)
            if key:
                self.log += [(now, f) for f in twin.release(key, now)]
            else:
                key = chance.randint(1, twin.description.face.keys)
                self.held[id(twin)] = key
                self.log += [(now, f) for f in twin.press(key, now)]
        elif roll < 0.40:  # the J1939 keypad: a key, or an LED command it acknowledges
            if chance.random() < 0.5:
                key = chance.randint(1, 12)
                self.log += [(now, f) for f in self.j1939.press(key, now)]
                self.log += [(now, f) for f in self.j1939.release(key, now + 0.05)]
            else:
                self._j1939(self._single_led.encode(chance.randint(1, 12), chance.randint(0, 9),
                                                    chance.randint(0, 3), chance.randint(0, 9)),
                            now)
        elif roll < 0.55:  # an SDO read the device answers
            twin, entry = chance.choice(self.readable)
            request = Frame(SDO_RX + twin.node_id, bytes((0x40,)) + entry.mux + bytes(4))
            self._all(request, now)
        elif roll < 0.70:
            twin = chance.choice(self.twins)
            self.log.append((now, Frame(HEARTBEAT + twin.node_id, b"\x05")))
        else:  # the controller sets LEDs, outputs, brightness
            layout, node = chance.choice(self.pdos)
            self._all(_random_pdo(layout, node, chance), now)


class OtherEcus:
    """Other ECUs: 11-bit proprietary frames and 29-bit J1939 engine and vehicle frames."""

    def __init__(self, chance: random.Random, taken: set[int]) -> None:
        self.chance = chance
        free = [i for i in range(0x001, 0x7FF) if i & 0x7F not in taken and i & 0x780 not in
                (NMT, 0x080, HEARTBEAT, SDO_RX, 0x580)]
        self.standard = [(i, chance.randint(2, 8), chance.random() < 0.5)
                         for i in chance.sample(free, 40)]
        self.extended = [(compose_id(pgn, source, priority=priority), 8, chance.random() < 0.3)
                         for priority, pgn in ENGINE_PGNS for source in
                         chance.sample(ENGINE_SOURCES, 2)]
        self.last: dict[tuple[int, bool], bytes] = {}

    def _data(self, key: tuple[int, bool], length: int, steady: bool) -> bytes:
        before = self.last.get(key)
        if before is None or not steady or self.chance.random() < 0.05:
            before = self.chance.randbytes(length)
            self.last[key] = before
        return before

    def standard_frame(self) -> Frame:
        ident, length, steady = self.chance.choice(self.standard)
        return Frame(ident, self._data((ident, False), length, steady))

    def extended_frame(self) -> Frame:
        ident, length, steady = self.chance.choice(self.extended)
        return Frame(ident, self._data((ident, True), length, steady), True)


def realistic_traffic(frames: int, seed: int = 22) -> list[tuple[float, Frame]]:
    """``frames`` frames: a third the devices', a third 11-bit and a third 29-bit of others."""
    chance = random.Random(seed)
    devices = _Devices(chance)
    others = OtherEcus(chance, set(device_nodes()))
    log: list[tuple[float, Frame]] = list(devices.log)  # power-on, NMT start, J1939 set-up
    now = 0.0
    while len(log) < frames:
        now += 0.0004
        roll = chance.random()
        if roll < 1 / 3:
            devices.log = []
            devices.step(now)
            log += [(now, frame) for _, frame in devices.log]
        elif roll < 2 / 3:
            log.append((now, others.standard_frame()))
        else:
            log.append((now, others.extended_frame()))
    return log[:frames]


def write_candump(path: Path, traffic: list[tuple[float, Frame]]) -> int:
    """The traffic as a candump ``-L`` log."""
    with path.open("w") as stream:
        for timestamp, item in traffic:
            ident = f"{item.can_id:08X}" if item.extended else f"{item.can_id:03X}"
            stream.write(f"({timestamp + 1_700_000_000:.6f}) can0 {ident}#"
                         f"{item.data.hex().upper()}\n")
    return len(traffic)
