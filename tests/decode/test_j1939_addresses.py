"""A J1939 keypad at any address (spec/pkp-2600-si-j1939.md §16): a capture that starts
mid-stream (no address claim, no heartbeat, no 70h command) decoded with and without
``--device j1939:ADDR=MODEL``, as text, JSON and Parquet rows, for every registered model that
has a J1939 mode. Without the option the bytes decide where they can (a key message is no
valid command) and nothing else is given a meaning (raw), never a made-up command."""

from __future__ import annotations

import json
from pathlib import Path

import can
import pytest
from click.testing import CliRunner

from blinkcan.cli.main import cli
from blinkcan.decode import Decoder, Kind
from blinkcan.decode.decoder import encode_json
from blinkcan.devices.keypad_j1939 import (
    DEFAULT_ADDRESS,
    NVM_PREFIX,
    PGN_COMMAND,
    PRIORITY,
    command,
)
from blinkcan.devices.model import Model
from blinkcan.devices.registry import models
from blinkcan.protocol import Frame
from blinkcan.protocol.j1939 import j1939_frame
from blinkcan.testing import Rig
from blinkcan.twin.registry import build_twin
from tests.conftest import frame
from tests.fleet.logs import write_log

J1939_MODELS = [m for m in models() if "j1939" in m.description().features]
ADDRESSES = [0x30, DEFAULT_ADDRESS]
CONTROLLER = 0x00  # the sender of the manual's examples (18EF2100h)
#: what the capture shows, in order: (who, what); "led KEY COLOUR STATE" is the controller's
#: §7a command, "tap KEY" a press and a release on the keypad
SCRIPT = ["led 5 1 1", "tap 5", "led 5 0 0", "led 3 2 2", "tap 3"]


def _command_frame(address: int, key: int, colour: int, state: int) -> Frame:
    data = command("single_led").encode(key, colour, state, 0)
    return j1939_frame(PGN_COMMAND, CONTROLLER, data, address, PRIORITY)


def capture(model: Model, address: int) -> list[tuple[float, Frame]]:
    """The keypad powered long before the capture starts (its address stored, so no 70h is
    ever on the bus; claim and heartbeat off, §5), the controller lighting LEDs, keys tapped."""
    with Rig() as rig:
        twin = rig.add(build_twin(model.name, protocol="j1939",
                                  settings={NVM_PREFIX + "source_address": address}))
        rig.advance(5.0)  # the startup show is over: the capture starts here, mid-stream
        start = rig.now
        for step in SCRIPT:
            verb, *numbers = step.split()
            values = [int(n) for n in numbers]
            if verb == "led":
                sent = _command_frame(address, *values)
                rig.bus.send(can.Message(arbitration_id=sent.can_id, data=sent.data,
                                         is_extended_id=True))
                rig.settle()
            else:
                rig.tap(twin, values[0])
            rig.advance(0.2)
        assert rig.snapshot(twin)["keys"][2]["phases"][0] == "green"  # the twin obeyed
        return [(timed.time, timed.frame) for timed in rig.frames_since(start)]


def _name(model: Model, address: int) -> str:
    return f"j1939:0x{address:02X}={model.name}"


@pytest.fixture(params=[(m, a) for m in J1939_MODELS for a in ADDRESSES],
                ids=lambda p: f"{p[0].name}-{p[1]:02X}h")
def keypad(request: pytest.FixtureRequest) -> tuple[Model, int]:
    found: tuple[Model, int] = request.param
    return found


def _expected(address: int, learned_from: int | None) -> list[str]:
    """The lines a decoder says; commands before index ``learned_from`` raw."""
    who = f"keypad {address:02X}h: "
    lines = [who + "LED 5 red", who + "key 5 pressed", who + "key 5 released",
             who + "LED 5 off", who + "LED 3 blinks green", who + "key 3 pressed",
             who + "key 3 released"]
    if learned_from is not None:
        lines[:learned_from] = [f"extended frame 18EF{address:02X}00h"
                                if "LED" in line else line for line in lines[:learned_from]]
    return lines


def test_the_python_decoder_names_the_keypad_with_and_without_its_address(
        keypad: tuple[Model, int]) -> None:
    model, address = keypad
    frames = [f for _, f in capture(model, address)]
    named = Decoder({f"j1939:0x{address:02X}": model.name})
    assert [str(named.decode(f)) for f in frames] == _expected(address, None)
    plain = Decoder()
    said = [str(plain.decode(f)) for f in frames]
    # 21h is the §5 default; another address is known from the keypad's first key message
    assert said == _expected(address, None if address == DEFAULT_ADDRESS else 1)
    assert not any("malformed" in line or "FFh" in line for line in said)


def test_decode_text_and_json_with_and_without_the_option(
        tmp_path: Path, keypad: tuple[Model, int]) -> None:
    model, address = keypad
    log = write_log(tmp_path / "mid.log", capture(model, address))
    runner = CliRunner()
    named = runner.invoke(cli, ["decode", str(log), "--device", _name(model, address)])
    assert named.exit_code == 0, named.output
    assert [line.split("  ")[-1] for line in named.stdout.splitlines()] == \
        _expected(address, None)
    plain = runner.invoke(cli, ["decode", str(log)])
    assert plain.exit_code == 0, plain.output
    assert [line.split("  ")[-1] for line in plain.stdout.splitlines()] == \
        _expected(address, None if address == DEFAULT_ADDRESS else 1)
    as_json = runner.invoke(cli, ["decode", str(log), "--json", "--device",
                                  _name(model, address)])
    events = [json.loads(line) for line in as_json.stdout.splitlines()]
    assert {(e["node"], e["device"], e["protocol"]) for e in events} == \
        {(address, model.description().kind, "j1939")}
    keys = [(e["key"], e["pressed"]) for e in events if e.get("message") == "key"]
    assert keys == [(5, True), (5, False), (3, True), (3, False)]
    leds = [(e["key"], e["colour"], e["state"]) for e in events
            if e.get("command") == "single_led"]
    assert leds == [(5, 1, 1), (5, 0, 0), (3, 2, 2)]


def test_parquet_rows_name_the_keypad_and_its_model(
        tmp_path: Path, keypad: tuple[Model, int]) -> None:
    pytest.importorskip("pyarrow")
    import pyarrow.dataset as ds

    model, address = keypad
    log = write_log(tmp_path / "mid.log", capture(model, address))
    for option, lake in (([], "plain"), (["--device", _name(model, address)], "named")):
        result = CliRunner().invoke(cli, ["decode", str(log), "--parquet",
                                          str(tmp_path / lake), *option])
        assert result.exit_code == 0, result.output
        table = ds.dataset(tmp_path / lake, format="parquet", partitioning="hive").to_table()
        rows = sorted(zip(table["time"].to_pylist(), table["kind"].to_pylist(),
                          table["node"].to_pylist(), table["model"].to_pylist(),
                          table["key"].to_pylist(), table["state"].to_pylist(),
                          table["colour"].to_pylist(), strict=True))
        kinds = [(kind, node, found, key, state, colour)
                 for _, kind, node, found, key, state, colour in rows]
        first_led = ("led", address, model.name, 5, "on", "red")
        if option or address == DEFAULT_ADDRESS:
            assert kinds[0] == first_led
        else:  # before the keypad's first key message nothing says 30h is a keypad: raw
            assert kinds[0] == ("undecoded", None, "unknown", None, None, None)
        assert kinds[1:] == [
            ("key", address, model.name, 5, "pressed", None),
            ("key", address, model.name, 5, "released", None),
            ("led", address, model.name, 5, "off", "off"),
            ("led", address, model.name, 3, "blink", "green"),
            ("key", address, model.name, 3, "pressed", None),
            ("key", address, model.name, 3, "released", None)]


def test_decode_files_takes_a_j1939_address(tmp_path: Path) -> None:
    pytest.importorskip("pyarrow")
    from blinkcan.fleet import decode_files

    model = J1939_MODELS[0]
    log = write_log(tmp_path / "mid.log", capture(model, 0x30))
    [result] = decode_files([log], str(tmp_path / "lake"), devices={"j1939:0x30": model.name})
    assert result.status == "decoded", result.error
    manifest = next((tmp_path / "lake" / "_blinkcan").glob("*.json"))
    assert json.loads(manifest.read_text())["settings"]["devices"] == \
        [["j1939:0x30", model.name]]
    with pytest.raises(ValueError, match="no J1939"):
        decode_files([log], str(tmp_path / "lake"), devices={"j1939:0x30": "keybox"})


@pytest.mark.parametrize(("text", "said"), [
    # a key message from an address nobody named: the bytes are no command (J-2), the
    # keypad's own: decoded and its address learned (it used to read "keypad FFh: malformed")
    ("18EFFF30 04 1B 01 05 01 21 FF FF", "keypad 30h: key 5 pressed"),
    ("18EF0030 04 1B 01 0C 00 30 FF FF", "keypad 30h: key 12 released"),  # after 6Eh 00h
    # open to both readings, or to none: raw
    ("18EF3000 04 1B 01 05 01 01 00 FF", "extended frame 18EF3000h"),  # command to 30h?
    ("18EFFF30 00 03 01 01 02 FF FF FF", "extended frame 18EFFF30h"),  # acknowledge?
    ("18EFFF30 04 1B 01 0D 01 21 FF FF", "extended frame 18EFFF30h"),  # key 13: neither
])
def test_the_bytes_decide_only_where_they_can(text: str, said: str) -> None:
    decoder = Decoder()
    assert str(decoder.decode(frame(text))) == said
    assert (0x30 in decoder.j1939.addresses) == said.startswith("keypad")


def test_a_named_address_replaces_the_default_and_is_checked() -> None:
    model = J1939_MODELS[0]
    decoder = Decoder({"j1939:0x30": model.name})
    assert decoder.j1939.addresses == {0x30}
    assert decoder.decode(frame("18EF2100 04 1B 01 05 01 01 00 FF")).kind is Kind.FRAME
    assert Decoder({0x15: "keypad"}).j1939.addresses == {DEFAULT_ADDRESS}  # CANopen only
    no_j1939 = next(m for m in models() if "j1939" not in m.description().features)
    with pytest.raises(ValueError, match="has no J1939 mode"):
        Decoder({"j1939:0x30": no_j1939.name})
    for wrong in ("j1939:0xFE", "j1939:0", "j1939:x"):
        with pytest.raises(ValueError, match="j1939"):
            Decoder({wrong: model.name})


@pytest.mark.parametrize("command_name", ["decode", "monitor"])
@pytest.mark.parametrize(("spec", "said"), [
    ("j1939:0x30=keybox", "has no J1939 mode"),
    ("j1939:0xFE=keypad", "0x1..0xfd"),
    ("j1939:thirty=keypad", "j1939:ADDR"),
])
def test_the_cli_refuses_a_device_it_cannot_name(tmp_path: Path, command_name: str,
                                                 spec: str, said: str) -> None:
    log = write_log(tmp_path / "empty.log", [])
    arguments = [str(log)] if command_name == "decode" else ["--file", str(log)]
    result = CliRunner().invoke(cli, [command_name, *arguments, "--device", spec])
    assert result.exit_code == 2
    assert said in result.output
    assert "Traceback" not in result.output


def test_help_says_how_to_name_a_j1939_keypad() -> None:
    for command_name in ("decode", "monitor"):
        result = CliRunner().invoke(cli, [command_name, "--help"])
        assert "j1939:0x30=keypad" in " ".join(result.output.split())


@pytest.mark.parametrize("frame", [
    Frame(0x18EFFF00, bytes.fromhex("041B2AFFFFFFFFFF"), True),  # §11 revision request
    Frame(0x18EFFF00, bytes.fromhex("041B0103010000FF"), True),  # §7a single LED
    Frame(0x18A7FF00, bytes.fromhex("1100000000000000"), True),  # §7b colour 1
    Frame(0x18A6FF00, bytes(8), True),  # §7b colour 2
], ids=["revision request", "single LED", "LEDs colour 1", "LEDs colour 2"])
def test_a_command_to_all_keypads_names_no_keypad_at_ffh(frame: Frame) -> None:
    """FFh is J1939's global address: every keypad takes the command (spec J-2), so it is
    no keypad's at FFh (the J1939 demo printed "keypad FFh: software revision request" and
    `monitor --file` drew a panel for a keypad FFh)."""
    decoder = Decoder({}, assumed=True)
    for _ in range(2):  # the second time from the decoder's kept frames
        event = decoder.decode(frame, 0.0)
        assert event.node_id is None
        assert str(event).endswith(", to all keypads")
        assert decoder.json_line(frame, 0.0) == encode_json(event.to_json())
    assert 0xFF not in decoder.j1939.addresses
