"""The same checks for every registered model, generation, quirk profile and protocol
(tests/conformance/cases.py reads them from the registry; issue 19): the twin boots and
answers its identity; scan names it; the registry's driver drives it (keys, LEDs or outputs,
backlight, heartbeat); the CLI commands that apply to it work against it; the EDS loads in
python-canopen and a RemoteNode reads its PDO configuration; the DBC loads in cantools; the
decoder names every frame of a session; every input its face has is a Rig call.

What applies to a case is read from its description (its face, features, PDOs), never from
its name: a model added to the registry is tested here as it is."""

from __future__ import annotations

import contextlib
import functools
import io
import time
import uuid
from collections.abc import Callable, Iterator
from typing import Any

import can
import canopen
import cantools
import pytest
from click.testing import CliRunner, Result

from blinkcan.cli.main import cli
from blinkcan.decode import Decoder
from blinkcan.decode.decoder import Kind
from blinkcan.formats.dbc import dbc_text
from blinkcan.formats.dbc_j1939 import dbc_text as j1939_dbc_text
from blinkcan.formats.eds import eds_text
from blinkcan.host import HostBus, scan
from blinkcan.host.device import HealthEvent
from blinkcan.host.j1939_keypad import scan_j1939
from blinkcan.host.registry import driver_class
from blinkcan.runtime import Emulator
from blinkcan.testing import Rig
from blinkcan.twin.base import CanopenTwin
from blinkcan.twin.registry import build_twin
from tests.conformance.cases import Case, cases

SETTLED = 10.0  # virtual seconds: past any start-up LED show


def _twin(case: Case) -> CanopenTwin:
    options: dict[str, Any] = {} if case.canopen else {"protocol": case.protocol}
    return build_twin(case.spec, quirks=case.quirks, **options)


def _address(case: Case, twin: CanopenTwin) -> int:
    """The source address of a twin in a protocol other than CANopen."""
    return int(getattr(twin, case.protocol).settings["source_address"])


def _driver(case: Case, bus: Any, twin: CanopenTwin) -> Any:
    driver = driver_class(case.model.name)
    if case.canopen:
        return driver(bus, twin.node_id)
    return driver(bus, twin.node_id, protocol=case.protocol, address=_address(case, twin))


@pytest.fixture
def rig() -> Iterator[Rig]:
    with Rig() as bench:
        yield bench


def _booted(rig: Rig, case: Case) -> CanopenTwin:
    twin = rig.add(_twin(case))
    rig.advance(SETTLED)
    return twin


# -- the twin boots and answers its identity; scan names it ---------------------------------------

@pytest.mark.parametrize("case", cases("identity"))
def test_the_twin_boots_and_answers_its_identity(rig: Rig, case: Case) -> None:
    twin = _booted(rig, case)
    assert rig.snapshot(twin)["powered"]
    table = case.description.table
    if not case.canopen:  # J1939 mode: its software revision (J1939 manual §11)
        found = scan_j1939(rig.bus, listen=0.2)
        assert [(f.address, bool(f.software_revision)) for f in found] == [
            (_address(case, twin), True)]
        return
    host = HostBus.attach(rig.bus)
    try:
        channel = host.sdo(twin.node_id, 0.5, 1)
        for name in ("device_type", "vendor_id", "model_id"):
            entry = table[name]
            assert entry.decode(channel.upload(entry.index, entry.subindex)) == entry.default
    finally:
        host.release()


@pytest.mark.parametrize("case", cases("scan"))
def test_scan_names_it(rig: Rig, case: Case) -> None:
    twin = _booted(rig, case)
    if not case.canopen:
        assert [f.address for f in scan_j1939(rig.bus, listen=0.2)] == [_address(case, twin)]
        return
    found = scan(rig.bus, listen=0.1, node_ids=range(twin.node_id, twin.node_id + 1))
    assert [(f.node_id, f.kind, f.model) for f in found] == [
        (twin.node_id, case.description.kind, case.description.model)]


# -- the registry's driver drives it ---------------------------------------------------------------

def _changed(rig: Rig, twin: CanopenTwin, action: Callable[[], object]) -> bool:
    """Whether ``action`` made the twin send a frame or change what it shows."""
    before, start = rig.snapshot(twin), rig.now
    action()
    rig.settle()
    sent = [t for t in rig.frames_since(start) if t.frame.can_id & 0x7F == twin.node_id
            or t.frame.extended]
    return bool(sent) or rig.snapshot(twin) != before


@pytest.mark.parametrize("case", cases("driver"))
def test_the_registry_driver_drives_it(rig: Rig, case: Case) -> None:
    twin = _booted(rig, case)
    face = case.description.face
    device = _driver(case, rig.bus, twin)
    try:
        rig.settle()
        if face.keys:
            events: list[Any] = []
            device.on_key(events.append)
            rig.tap(twin, face.key_numbers[-1])
            assert [(e.key, e.action) for e in events][:2] == [
                (face.key_numbers[-1], "press"), (face.key_numbers[-1], "release")]
        if face.led_keys:
            key = face.led_keys[-1]
            device.set_led(key, "red")
            rig.settle()
            assert rig.snapshot(twin)["keys"][key - 1]["colour"] == "red"
        if face.pins:
            pin = face.pin_numbers[-1]
            device.on(pin)
            rig.settle()
            assert rig.snapshot(twin)["pins"][pin - 1]["state"] == "high"
            device.off(pin)
            rig.settle()
            assert rig.snapshot(twin)["pins"][pin - 1]["state"] == "off"
        if hasattr(device, "set_backlight"):
            device.set_backlight(level=20)
            rig.settle()
            assert rig.snapshot(twin)["backlight"]["level"] == 20
    finally:
        device.close()


@pytest.mark.parametrize("case", cases("heartbeat"))
def test_the_driver_follows_its_heartbeat(rig: Rig, case: Case) -> None:
    twin = _booted(rig, case)
    device = _driver(case, rig.bus, twin)
    try:
        health: list[HealthEvent] = []
        device.on_health(health.append)
        device.monitor_heartbeat(0.1)
        rig.advance(0.5)
        assert device.alive
        rig.power_off(twin)
        rig.advance(0.5)
        assert [event.kind for event in health][-1:] == ["lost"]
    finally:
        device.close()


# -- every input the face has is a Rig call; the decoder names every frame ------------------------

def _inputs(rig: Rig, twin: CanopenTwin, case: Case) -> dict[str, Callable[[], object]]:
    face = case.description.face
    found: dict[str, Callable[[], object]] = {}
    for key in face.key_numbers:
        found[f"key {key}"] = functools.partial(rig.tap, twin, key)
    for encoder in face.encoders:
        found[f"encoder {encoder.number}"] = functools.partial(rig.turn, twin, encoder.number, 1)
    for number in range(face.analog_inputs):
        found[f"analog {number}"] = functools.partial(rig.set_analog, twin, number,
                                                      face.analog_volts_max / 2)
    for number in range(face.digital_inputs):
        found[f"digital {number}"] = functools.partial(rig.set_digital_input, twin, number, True)
    for pin in face.pin_numbers:
        found[f"fuse {pin}"] = functools.partial(rig.blow_fuse, twin, pin)
        found[f"input {pin}"] = functools.partial(rig.set_input, twin, pin, True)
    return found


@pytest.mark.parametrize("case", cases("inputs"))
def test_rig_reaches_every_input_and_the_decoder_names_every_frame(rig: Rig, case: Case
                                                                   ) -> None:
    twin = _booted(rig, case)
    if case.canopen:  # operational: inputs are reported by PDOs
        device = _driver(case, rig.bus, twin)
        device.close()
    inputs = _inputs(rig, twin, case)
    assert inputs, "the face has no input"
    unreached = [name for name, action in inputs.items() if not _changed(rig, twin, action)]
    assert unreached == []
    decoder = Decoder({twin.node_id: case.description})
    unnamed = {f"{t.frame.can_id:03X}" for t in rig.frames
               if decoder.decode(t.frame, t.time).kind is Kind.FRAME}
    assert unnamed == set()


# -- the CLI against an emulated device -----------------------------------------------------------

@contextlib.contextmanager
def _live(case: Case) -> Iterator[tuple[list[str], Emulator, CanopenTwin, list[str]]]:
    """The case's twin in an Emulator on a virtual bus (as ``blinkcan emulate`` runs it), the
    bus options for the CLI, and the group options that reach the twin."""
    channel = f"conformance-{uuid.uuid4().hex}"
    bus = can.Bus(interface="virtual", channel=channel)
    twin = _twin(case)
    twin.power_on(0.0)
    where = ["--node-id", f"0x{twin.node_id:02X}"]
    if not case.canopen:
        where += ["--protocol", case.protocol, "--address", f"0x{_address(case, twin):02X}"]
    try:
        with Emulator(bus, [twin]) as emulator:
            yield ["-i", "virtual", "-c", channel], emulator, twin, where
    finally:
        bus.shutdown()


def _run(*args: str) -> Result:
    return CliRunner().invoke(cli, list(args), env={"COLUMNS": "200"})


def _until(predicate: Callable[[], object], timeout: float = 2.0) -> None:
    end = time.monotonic() + timeout
    while not predicate():
        assert time.monotonic() < end, "timed out"
        time.sleep(0.01)


def _holds(emulator: Emulator, done: Callable[[], object]) -> bool:
    """``done()`` on the emulator's thread (the twin's state as it is between frames)."""
    return bool(emulator.run(lambda now: done()))


def _cli_commands(case: Case, twin: CanopenTwin) -> list[tuple[list[str], Callable[[], object]]]:
    """(the command's words after the group, what must be true after it) for the case."""
    face = case.description.face
    commands: list[tuple[list[str], Callable[[], object]]] = []
    if face.led_keys:
        key = face.led_keys[-1]
        commands.append((["led", str(key), "red"],
                         lambda: twin.snapshot()["keys"][key - 1]["colour"] == "red"))
    if face.pins:
        pin = face.pin_numbers[-1]
        commands.append((["on", str(pin)],
                         lambda: twin.snapshot()["pins"][pin - 1]["state"] == "high"))
        commands.append((["off", str(pin)],
                         lambda: twin.snapshot()["pins"][pin - 1]["state"] == "off"))
    if face.encoders:
        led = face.encoders[0].ring_leds[0]
        commands.append((["ring", "1", str(led)], lambda: True))
        commands.append((["encoder", "1"], lambda: True))
    if face.analog_inputs or face.digital_inputs:
        commands.append((["inputs"], lambda: True))
    return commands


@pytest.mark.parametrize("case", cases("cli"))
def test_the_cli_commands_that_apply_work(case: Case) -> None:
    failures = []
    with _live(case) as (bus, emulator, twin, where):
        for words, done in _cli_commands(case, twin):
            result = _run(case.model.kind, *where, *words, *bus)
            if result.exit_code != 0:
                failures.append(f"{' '.join(words)}: {result.output.strip()}")
                continue
            try:
                _until(functools.partial(_holds, emulator, done))
            except AssertionError:
                failures.append(f"{' '.join(words)}: no effect on the device")
        listed = " ".join(_run("scan", "--listen", "0.2", *bus).output.split())
    named = (str(case.description.table["model_id"].default) if case.canopen
             else f"{case.model.kind} ({case.protocol.upper()})")
    if named not in listed:
        failures.append(f"scan does not name it: {listed}")
    assert failures == []


@pytest.mark.parametrize("case", cases("cli-info"))
def test_the_cli_info_names_it(case: Case) -> None:
    with _live(case) as (bus, _, _, where):
        result = _run(case.model.kind, *where, "info", *bus)
    assert result.exit_code == 0, result.output
    description = case.description
    assert description.model in result.output or description.title in result.output


# -- the files other tools read ------------------------------------------------------------------

@pytest.mark.parametrize("case", cases("eds"))
def test_the_eds_loads_in_python_canopen_and_a_remote_node_reads_its_pdos(rig: Rig, case: Case
                                                                         ) -> None:
    twin = _booted(rig, case)
    if not case.canopen:  # a keypad in J1939 mode answers no SDO: its DBC is what tools read
        return
    text = io.StringIO(eds_text(case.description))
    text.name = "exported.eds"
    network: Any = canopen.Network(rig.bus)
    network.connect()
    try:
        node: Any = canopen.RemoteNode(twin.node_id, text)
        network.add_node(node)
        node.tpdo.read()
        node.rpdo.read()
        cob_ids = {pdo.cob_id for pdos in (node.tpdo, node.rpdo) for pdo in pdos.map.values()}
    finally:
        network.disconnect()
    assert cob_ids == {layout.cob_id(twin.node_id) for layout in case.description.pdos}


@pytest.mark.parametrize("case", cases("dbc"))
def test_the_dbc_loads_in_cantools(case: Case) -> None:
    if case.canopen:
        text = dbc_text(case.description, case.model.default_node_id)
        expected = {layout.cob_id(case.model.default_node_id) for layout in case.description.pdos}
    else:
        twin = _twin(case)
        text = j1939_dbc_text(_address(case, twin))
        expected = set()
    database: Any = cantools.database.load_string(text, "dbc")
    ids = {message.frame_id for message in database.messages}
    assert ids
    assert expected <= ids
