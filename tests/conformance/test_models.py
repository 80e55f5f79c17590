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
import json
import time
import uuid
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import can
import canopen
import cantools
import click
import pytest
from click.testing import CliRunner, Result

from blinkcan.cli.main import cli
from blinkcan.decode import Decoder
from blinkcan.decode.decoder import Kind
from blinkcan.formats.eds import eds_text
from blinkcan.host import HostBus, scan
from blinkcan.host.device import HealthEvent
from blinkcan.host.j1939_keypad import scan_j1939
from blinkcan.host.registry import driver_class
from blinkcan.runtime import Emulator, to_message
from blinkcan.testing import Rig
from blinkcan.twin.base import CanopenTwin
from blinkcan.twin.registry import build_twin
from tests.conformance.cases import CASES, Case, cases

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

def _inputs(rig: Rig, twin: CanopenTwin, case: Case) -> dict[str, functools.partial[None]]:
    """Every input of the case's face as a Rig call, in an order where each changes something
    (a fuse is blown before it is replaced, an input set high before low)."""
    face = case.description.face
    found: dict[str, functools.partial[None]] = {}
    for key in face.key_numbers:
        found[f"key {key}"] = functools.partial(rig.tap, twin, key)
    for key in face.key_numbers[-1:]:
        found[f"key {key} down"] = functools.partial(rig.press, twin, key)
        found[f"key {key} up"] = functools.partial(rig.release, twin, key)
        found[f"key {key} held"] = functools.partial(rig.long_press, twin, key)
    for encoder in face.encoders:
        found[f"encoder {encoder.number}"] = functools.partial(rig.turn, twin, encoder.number, 1)
        found[f"encoder {encoder.number} back"] = functools.partial(rig.turn, twin,
                                                                    encoder.number, -1)
    for number in range(face.analog_inputs):
        found[f"analog {number}"] = functools.partial(rig.set_analog, twin, number,
                                                      face.analog_volts_max / 2)
    for number in range(face.digital_inputs):
        found[f"digital {number}"] = functools.partial(rig.set_digital_input, twin, number, True)
        found[f"digital {number} low"] = functools.partial(rig.set_digital_input, twin, number,
                                                           False)
    for pin in face.pin_numbers:
        found[f"fuse {pin}"] = functools.partial(rig.blow_fuse, twin, pin)
        found[f"fuse {pin} replaced"] = functools.partial(rig.replace_fuse, twin, pin)
        found[f"input {pin}"] = functools.partial(rig.set_input, twin, pin, True)
        found[f"input {pin} low"] = functools.partial(rig.set_input, twin, pin, False)
    return found


#: the Rig's public members that are not a device's inputs (time, frames, twins, faults)
NOT_INPUTS = {"now", "frames", "frames_since", "advance", "settle", "catch_up", "until", "add",
              "twins", "twin", "act", "snapshot", "power_off", "power_on", "power_cycle", "drop",
              "delay", "drop_node", "stop_heartbeat", "busy", "bus_down", "bus_up", "close"}


@pytest.mark.parametrize("case", cases("inputs"))
def test_rig_reaches_every_input_and_the_decoder_names_every_frame(rig: Rig, case: Case
                                                                   ) -> None:
    twin, unreached = _session(rig, case)
    assert unreached == []
    decoder = Decoder({twin.node_id: case.description})
    unnamed = {f"{t.frame.can_id:03X}" for t in rig.frames
               if decoder.decode(t.frame, t.time).kind is Kind.FRAME}
    assert unnamed == set()


def _session(rig: Rig, case: Case) -> tuple[CanopenTwin, list[str]]:
    """The case's twin booted, started by its driver and given every input its face has; the
    inputs that changed nothing."""
    twin = _booted(rig, case)
    if case.canopen:  # operational: inputs are reported by PDOs
        device = _driver(case, rig.bus, twin)
        device.close()
    inputs = _inputs(rig, twin, case)
    assert inputs, "the face has no input"
    return twin, [name for name, action in inputs.items() if not _changed(rig, twin, action)]


@pytest.mark.parametrize("case", cases("decode"))
def test_decode_and_monitor_name_a_session(rig: Rig, case: Case, tmp_path: Path) -> None:
    """``blinkcan decode`` and ``monitor --file`` of a log of every input the face has."""
    twin, _ = _session(rig, case)
    log = tmp_path / "session.asc"
    with can.Logger(str(log)) as writer:
        for timed in rig.frames:
            message = to_message(timed.frame)
            message.timestamp = timed.time
            writer(message)
    device = ["--device", f"0x{twin.node_id:02X}={case.spec}"]
    decoded = _run("decode", str(log), "--json", *device)
    assert decoded.exit_code == 0, decoded.output
    lines = [json.loads(line) for line in decoded.output.splitlines()]
    assert len(lines) == len(rig.frames)
    assert [line for line in lines if line["kind"] == Kind.FRAME.value] == []
    monitored = _run("monitor", "--file", str(log), "--speed", "1000", *device)
    assert monitored.exit_code == 0, monitored.output
    assert lines[-1]["text"] in monitored.output


def test_every_input_helper_of_the_rig_is_in_the_inputs_check(rig: Rig) -> None:
    """A new Rig helper for an input is reached for every model whose face has the input."""
    helpers = {name for name in dir(Rig) if not name.startswith("_")} - NOT_INPUTS
    used = {action.func.__name__ for case in CASES
            for action in _inputs(rig, _twin(case), case).values()}
    assert used == helpers


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


@dataclass(frozen=True)
class CliCheck:
    """One command against the device: its words (after the device's group and node options,
    or after ``blinkcan`` when ``top_level``), what must hold on the twin's snapshot after it,
    and what its output must say."""

    words: tuple[str, ...]
    holds: Callable[[dict[str, Any]], object] = lambda snapshot: True
    says: str = ""
    top_level: bool = False


def _heartbeat_ms(case: Case, snapshot: dict[str, Any]) -> int:
    """The producer heartbeat period the twin runs (a protocol of its own keeps its own)."""
    settings = snapshot if case.canopen else snapshot[case.protocol]
    return int(settings["heartbeat_ms"])


def _field_is(path: tuple[str | int, ...], value: object
              ) -> Callable[[dict[str, Any]], object]:
    """Whether the snapshot's field at ``path`` is ``value``."""

    def holds(snapshot: dict[str, Any]) -> object:
        found: Any = snapshot
        for step in path:
            found = found[step]
        return bool(found == value)

    return holds


def _snapshot_holds(check: CliCheck, twin: CanopenTwin) -> object:
    return check.holds(twin.snapshot())


def _free_node(node: int) -> int:
    return node + 1 if node < 127 else node - 1


#: a CLI command that may apply to a device -> its checks for a case and the twin's snapshot
#: before the commands ([]: it does not apply to the case). Run in this order: a node id moves
#: last, an NMT stop is followed by a start.
CLI_CHECKS: dict[str, Callable[[Case, dict[str, Any]], list[CliCheck]]] = {
    "nmt": lambda case, s: [
        CliCheck(("nmt", "stop", str(s["node_id"])), lambda t: t["nmt_state"] == "stopped",
                 top_level=True),
        CliCheck(("nmt", "start", str(s["node_id"])), lambda t: t["nmt_state"] == "operational",
                 top_level=True)] if case.canopen else [],
    # one name for the model in either protocol: the registered one (what --model takes)
    "info": lambda case, s: [CliCheck(("info",), says=f"model             "
                                      f"{case.description.model}\n")],
    "led": lambda case, s: [
        CliCheck(("led", str(key), "red"), _field_is(("keys", key - 1, "colour"), "red"))
        for key in case.description.face.led_keys[-1:]],
    "backlight": lambda case, s: [
        CliCheck(("backlight", "--level", "20"), lambda t: t["backlight"]["level"] == 20)
    ] if "backlight_brightness" in case.description.table else [],
    "brightness": lambda case, s: [
        CliCheck(("brightness", "30"), lambda t: t["indicator_brightness"] == 30)
    ] if "indicator_brightness" in case.description.table else [],
    "heartbeat": lambda case, s: [
        CliCheck(("heartbeat", "100"), lambda t: _heartbeat_ms(case, t) == 100)],
    "write": lambda case, s: [
        CliCheck(("write", "producer_heartbeat_time", "250"),
                 lambda t: _heartbeat_ms(case, t) == 250)] if case.canopen else [],
    "read": lambda case, s: [
        CliCheck(("read", "vendor_id"), says=str(case.description.table["vendor_id"].default))
    ] if case.canopen else [],  # J1939 mode answers no SDO
    "on": lambda case, s: [
        CliCheck(("on", str(pin)), _field_is(("pins", pin - 1, "state"), "high"))
        for pin in case.description.face.pin_numbers[-1:]],
    "off": lambda case, s: [
        CliCheck(("off", str(pin)), _field_is(("pins", pin - 1, "state"), "off"))
        for pin in case.description.face.pin_numbers[-1:]],
    "pwm": lambda case, s: [
        CliCheck(("pwm", str(pin), "5"), _field_is(  # 5 tenths: 50 % (KBX §22)
            ("pins", pin - 1, "pwm_percent"), 5 * (100 // case.description.face.pwm_duty_max)))
        for pin in case.description.face.pwm_pins[-1:]],
    "reset": lambda case, s: [
        CliCheck(("reset", str(pin)), _field_is(("pins", pin - 1, "state"), "off"))
        for pin in case.description.face.pin_numbers[-1:]],
    "states": lambda case, s: [
        CliCheck(("states",), says=f"pin {pin:>2}: ")
        for pin in case.description.face.pin_numbers[-1:]],
    "faults": lambda case, s: [
        CliCheck(("faults",), says="FAULT") for _ in case.description.face.pin_numbers[:1]],
    "ring": lambda case, s: [
        CliCheck(("ring", str(encoder.number), str(encoder.ring_leds[0])),
                 lambda t: t["encoders"][0]["ring"][0]["on"])
        for encoder in case.description.face.encoders[:1]],
    "encoder": lambda case, s: [
        CliCheck(("encoder", str(encoder.number), "--top", "5"),
                 lambda t: t["encoders"][0]["top"] == 5, says="top 5")
        for encoder in case.description.face.encoders[:1]],
    "inputs": lambda case, s: [
        CliCheck(("inputs",), says="IN0:") for _ in range(
            min(1, case.description.face.analog_inputs + case.description.face.digital_inputs))],
    "set-baud": lambda case, s: [  # the rate in use: nothing changes at the next reset
        CliCheck(("set-baud", str(s["bitrate"]), "--yes"), says=f"bit rate {s['bitrate']}")],
    "restore-defaults": lambda case, s: [
        CliCheck(("restore-defaults", "--yes"), says="factory defaults restored")
    ] if case.canopen and "restore_all_parameters" in case.description.table else [],
    "set-node-id": lambda case, s: [  # over another protocol: its address
        CliCheck(("set-node-id", str(_free_node(s["node_id"])), "--yes"),
                 _field_is(("settings", "node_id"), _free_node(s["node_id"])))
    ] if case.canopen else [
        CliCheck(("set-node-id", str(_free_node(s[case.protocol]["source_address"])), "--yes"),
                 _field_is((case.protocol, "source_address"),
                           _free_node(s[case.protocol]["source_address"])))],
}

#: commands of the command line that do not name a device model, and why
NOT_PER_DEVICE = {
    "convert": "converts log formats, frames only",
    "record": "records any bus, frames only",
    "query": "SQL on a decoded dataset (tests/fleet/)",
    "demo": "its own keypad and Keybox (tests/cli/)",
}
#: commands checked per case by other tests of this suite
ELSEWHERE = {
    "scan": "test_the_cli_commands_that_apply_work",
    "emulate": "test_panel.py",
    "act": "tests/cli/test_typed_commands.py (every case's actions), tests/cli/test_act.py",
    "export": "test_exports.py, test_the_dbc_loads_in_cantools",
    "decode": "test_decode_and_monitor_name_a_session",
    "monitor": "test_decode_and_monitor_name_a_session",
}


def _commands(group: Any) -> list[str]:
    """The names of a click group's commands (the root group imports them when they run)."""
    return list(group.list_commands(click.Context(group)))


def _subcommands(kind: str) -> list[str]:
    group = cli.get_command(click.Context(cli), kind)
    return _commands(group)


def test_every_cli_command_is_checked_for_every_case() -> None:
    """A new command (or subcommand of a device's group) fails here until the suite says what
    it checks for each case."""
    kinds = {case.model.kind for case in CASES}
    group_commands = {name for kind in kinds for name in _subcommands(kind)}
    assert group_commands - set(CLI_CHECKS) == set()
    top = set(_commands(cli)) - kinds
    assert top == (set(CLI_CHECKS) - group_commands) | set(NOT_PER_DEVICE) | set(ELSEWHERE)


def _in_canopen(case: Case) -> Case:
    return Case(case.model, case.generation, case.quirks, "canopen")


def _refused(case: Case, snapshot: dict[str, Any], group: list[str]) -> list[str]:
    """The device group's commands that do not apply to the case in its protocol although they
    apply in CANopen: the command line refuses them (a usage error, before the bus)."""
    if case.canopen:
        return []
    return [name for name in group if name in CLI_CHECKS and not CLI_CHECKS[name](case, snapshot)
            and CLI_CHECKS[name](_in_canopen(case), snapshot)
            and not CLI_CHECKS[name](_in_canopen(case), snapshot)[0].top_level]


@pytest.mark.parametrize("case", cases("cli"))
def test_the_cli_commands_that_apply_work(case: Case) -> None:
    failures = []
    with _live(case) as (bus, emulator, twin, where):
        before = emulator.run(lambda now: twin.snapshot())
        group = _subcommands(case.model.kind)
        for name in _refused(case, before, group):  # what the protocol has no message for
            words = [case.model.kind, *where, *CLI_CHECKS[name](_in_canopen(case), before)[0].words]
            result = _run(*words, *bus)
            if result.exit_code != 2 or not result.output.startswith("Error: "):
                failures.append(f"{name} in {case.protocol}: not refused: {result.output}")
        for name, checks in CLI_CHECKS.items():
            for check in checks(case, before):
                if not check.top_level and name not in group:
                    failures.append(f"{name}: not a {case.model.kind} command")
                    continue
                words = (list(check.words) if check.top_level
                         else [case.model.kind, *where, *check.words])
                result = _run(*words, *bus)
                said = " ".join(check.words)
                if result.exit_code != 0:
                    failures.append(f"{said}: {result.output.strip()}")
                elif check.says not in result.output:
                    failures.append(f"{said} does not say {check.says!r}: {result.output}")
                else:
                    try:
                        _until(functools.partial(_holds, emulator, functools.partial(
                            _snapshot_holds, check, twin)))
                    except AssertionError:
                        failures.append(f"{said}: no effect on the device")
        listed = " ".join(_run("scan", "--listen", "0.2", *bus).output.split())
    named = [case.description.model] + (
        [] if case.canopen else [f"{case.model.kind} ({case.protocol.upper()})"])
    if not all(name in listed for name in named):
        failures.append(f"scan does not name it: {listed}")
    assert failures == []


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
def test_the_dbc_loads_in_cantools(rig: Rig, case: Case, tmp_path: Path) -> None:
    """``blinkcan export dbc``'s file has a message for each of the device's PDOs; in J1939
    mode, for every frame it sends in a session of every input."""
    twin, _ = _session(rig, case)
    path = tmp_path / "device.dbc"
    options = (["--node-id", str(twin.node_id)] if case.canopen else
               ["--protocol", case.protocol, "--address", str(_address(case, twin))])
    result = _run("export", "dbc", case.spec, *options, "-o", str(path))
    assert result.exit_code == 0, result.output
    database: Any = cantools.database.load_file(str(path))
    ids = {message.frame_id | (0x80000000 if message.is_extended_frame else 0)
           for message in database.messages}
    expected = ({layout.cob_id(twin.node_id) for layout in case.description.pdos} if case.canopen
                else {t.frame.can_id | 0x80000000 for t in rig.frames if t.frame.extended})
    assert expected
    assert sorted(expected - ids) == []
