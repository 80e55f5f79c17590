"""The PKP-3500-MT through every face: driver, scan, decoder, monitor view, EDS (read back by
python-canopen, and a RemoteNode reading every object of the twin), DBC, the CLI."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import cantools
import pytest
from click.testing import CliRunner

from blinkcan.cli.main import cli
from blinkcan.decode import Decoder
from blinkcan.decode.view import BusView
from blinkcan.devices.objects import ObjectKind
from blinkcan.devices.registry import describe_device, identify
from blinkcan.formats.dbc import dbc_text
from blinkcan.formats.eds import eds_text
from blinkcan.formats.shipped import shipped_eds
from blinkcan.host import Keypad
from blinkcan.host.pkp3500 import EncoderEvent, Pkp3500Keypad
from blinkcan.protocol import Frame
from blinkcan.testing import Rig
from blinkcan.twin import KeypadTwin
from blinkcan.twin.pkp3500 import Pkp3500Twin

MT = "pkp-3500-mt"


def mt_twin(**kwargs: object) -> KeypadTwin:
    return KeypadTwin(node_id=0x15, model=MT, **kwargs)  # type: ignore[arg-type]


def test_keypad_twin_builds_the_model_the_registry_names() -> None:
    twin = mt_twin()
    assert isinstance(twin, Pkp3500Twin)
    assert twin.description.model == MT
    assert twin.description.face.keys == 15
    with pytest.raises(ValueError, match=r"key 16 outside 1..15"):
        twin.press(16, 0.0)
    with pytest.raises(ValueError, match=r"encoder 3 outside 1..2"):
        twin.turn(3, 1, 0.0)
    with pytest.raises(ValueError, match=r"input 4 outside 0..3"):
        twin.set_analog(4, 1.0, 0.0)
    with pytest.raises(ValueError, match="volts must be a number >= 0"):
        twin.set_analog(0, -1.0, 0.0)


def test_the_2600_stays_the_default_model() -> None:
    assert KeypadTwin().description.model == "pkp-2600-si"


def test_identity_names_the_model_by_100b() -> None:
    found = identify(device_type=0x000B0191, model_id="PKP3500MT")
    assert found is not None
    assert found.model == MT


# -- driver ---------------------------------------------------------------------------------------

def quiet(twin: KeypadTwin) -> KeypadTwin:
    twin.power_on(0.0)
    twin.receive(Frame(0x615, bytes.fromhex("2F14200000000000")), 0.0)  # no startup show
    twin.power_off()
    return twin


def test_driver_encoder_events_ring_leds_and_inputs() -> None:
    with Rig() as rig:
        twin = rig.add(quiet(mt_twin()))
        keypad = Keypad(rig.bus, 0x15, model=MT)
        assert isinstance(keypad, Pkp3500Keypad)
        rig.settle()
        events: list[EncoderEvent] = []
        keypad.on_encoder(events.append)
        keypad.set_top(1, 0)
        rig.act(lambda now: twin.turn(1, -2, now))  # type: ignore[attr-defined]
        rig.act(lambda now: twin.turn(2, 3, now))  # type: ignore[attr-defined]
        rig.settle()
        assert [(e.encoder, e.ticks, e.counter, e.top, e.direction) for e in events] == [
            (1, -1, 0xFFFF, 0, "counterclockwise"), (1, -1, 0xFFFE, 0, "counterclockwise"),
            (2, 1, 1, 8, "clockwise"), (2, 1, 2, 8, "clockwise"), (2, 1, 3, 8, "clockwise")]
        assert keypad.read_counter(2) == 3
        keypad.set_ring(1, [1, 2, 16])
        keypad.set_ring(2, [17])
        rig.settle()
        assert twin.objects["led_on_rings"] == 0x0001_8003
        assert keypad.ring(1) == [1, 2, 16]
        with pytest.raises(ValueError, match=r"ring 2 has LEDs 17..32"):
            keypad.set_ring(2, [3])
        keypad.set_led(2, "green")
        rig.settle()
        assert twin.snapshot()["keys"][1]["colour"] == "green"
        with pytest.raises(ValueError, match="key 11 has no LED"):
            keypad.set_led(11, "red")
        keypad.set_brightness(20)  # SDO, not 415h (M56)
        assert twin.objects["indicator_brightness"] == 20
        assert twin.objects["led_on_rings"] == 0x0001_8003
        rig.act(lambda now: twin.set_analog(2, 3.0, now))  # type: ignore[attr-defined]
        rig.act(lambda now: twin.set_digital_input(0, True, now))  # type: ignore[attr-defined]
        rig.advance(0.1)
        assert keypad.analog == {0: 5.0, 1: 0.0, 2: 3.0, 3: 0.0}
        assert keypad.read_analog(2) == 3.0
        assert keypad.digital_inputs() == {0: True, 1: False, 2: True, 3: False}
        keypad.set_analog_period(0.5)
        assert twin.objects["analog_period"] == 50
        rig.power_cycle(twin)
        rig.settle()
        assert twin.objects["led_on_rings"] == 0x0001_8003  # restored after the boot-up
        keypad.close()


def test_driver_connect_reads_the_model_id() -> None:
    with Rig() as rig:
        rig.add(mt_twin())
        rig.add(KeypadTwin(node_id=0x16))
        assert isinstance(Keypad.connect(rig.bus, 0x15, start=False), Pkp3500Keypad)
        plain = Keypad.connect(rig.bus, 0x16, start=False)
        assert type(plain) is Keypad


# -- decoder, monitor view ------------------------------------------------------------------------

@pytest.mark.parametrize(("frame", "text"), [
    (Frame(0x295, bytes.fromhex("81FFFF0000000000")),
     "keypad 15h: encoder 1 state: ticks since the last report -1, tick counter 65535, "
     "top position 0"),
    (Frame(0x395, bytes.fromhex("0110001000000000")),
     "keypad 15h: encoder 2 state: ticks since the last report 1, tick counter 16, "
     "top position 16"),
    (Frame(0x495, bytes.fromhex("F401C8002C016400")),
     "keypad 15h: analog inputs: in0 5 V, in1 2 V, in2 3 V, in3 1 V"),
    (Frame(0x415, bytes.fromhex("0300C00000000000")),
     "keypad 15h: set encoder leds on: ring LED 1, 2, 23, 24"),
    (Frame(0x215, bytes.fromhex("000000400040")), "keypad 15h: LEDs on: green 15; blue 15"),
    (Frame(0x195, bytes.fromhex("0041000012")), "keypad 15h: key 9, 15 pressed"),
])
def test_decoder_reads_the_model_from_its_description(frame: Frame, text: str) -> None:
    decoder = Decoder({0x15: MT})
    assert str(decoder.decode(frame)) == text


def test_decoder_learns_the_model_from_100b_after_1000h() -> None:
    decoder = Decoder()
    decoder.decode(Frame(0x615, bytes.fromhex("4000100000000000")))
    decoder.decode(Frame(0x595, bytes.fromhex("430010009101 0B00".replace(" ", ""))))
    assert decoder.device(0x15).model == "pkp-2600-si"  # type: ignore[union-attr]
    decoder.decode(Frame(0x615, bytes.fromhex("400B100000000000")))
    decoder.decode(Frame(0x595, bytes.fromhex("410B100009000000")))
    decoder.decode(Frame(0x615, bytes.fromhex("6000000000000000")))
    decoder.decode(Frame(0x595, bytes.fromhex("00504B5033353030")))
    decoder.decode(Frame(0x615, bytes.fromhex("7000000000000000")))
    decoder.decode(Frame(0x595, bytes.fromhex("1B4D540000000000")))
    assert decoder.device(0x15).model == MT  # type: ignore[union-attr]


def test_monitor_view_keeps_the_knobs_and_inputs() -> None:
    decoder = Decoder({0x15: MT})
    view = BusView(decoder)
    for frame in (Frame(0x195, bytes.fromhex("0004000000")),
                  Frame(0x295, bytes.fromhex("0103000800000000"))):
        view.update(decoder.decode(frame))
    node = view.nodes[0x15]
    assert node.held == [11]
    assert [key for key, _, _ in node.key_colours()] == list(range(1, 16))
    assert node.other["encoder_1"].startswith("encoder 1 state: ticks since the last report 1")


# -- EDS, DBC -------------------------------------------------------------------------------------

def test_shipped_eds_matches_a_fresh_export_and_python_canopen_reads_it() -> None:
    import canopen

    description = describe_device(MT)
    path = shipped_eds(description)
    assert path.name == "pkp-3500-mt.eds"
    assert path.read_text() == eds_text(description)
    od: Any = canopen.import_od(str(path), 0x15)
    assert od[0x2000][7].default == 8  # TOP position encoder 2 (MT §3)
    assert od[0x2005][4].name == "Analog input IN3 (FFh at 5 V)"
    assert od[0x1803][2].access_type == "ro"
    assert len(od[0x1A03]) == 1  # stated empty for readers that pair 1803h with it (M50)


def test_a_remote_node_from_the_eds_reads_every_object_of_the_twin() -> None:
    import can
    import canopen

    from blinkcan.runtime import Emulator

    description = describe_device(MT)
    twin = mt_twin()
    bus = can.Bus(interface="virtual", channel="mt-eds")
    network = canopen.Network()
    network.connect(interface="virtual", channel="mt-eds")
    try:
        with Emulator(bus, [twin]):
            node = network.add_node(0x15, str(shipped_eds(description)))
            read = 0
            for obj in description.table.objects:
                for entry in obj.entries:
                    item: Any = node.sdo[entry.index]
                    if obj.kind is not ObjectKind.VAR:
                        item = item[entry.subindex]
                    assert item.raw is not None, f"{entry.index:04X}/{entry.subindex}"
                    read += 1
            assert read == len(list(description.table))
    finally:
        network.disconnect()
        bus.shutdown()


def test_dbc_has_every_pdo_with_units() -> None:
    database = cantools.database.load_string(dbc_text(describe_device(MT), 0x15))
    assert isinstance(database, cantools.database.can.Database)
    names = {message.frame_id for message in database.messages}
    assert {0x195, 0x295, 0x395, 0x495, 0x215, 0x315, 0x415, 0x515} <= names
    analog = database.get_message_by_frame_id(0x495)
    decoded = analog.decode(bytes.fromhex("F401C8002C016400"))
    assert decoded == {"in0": 5.0, "in1": 2.0, "in2": 3.0, "in3": 1.0}  # MT §14 examples
    assert analog.get_signal_by_name("in0").unit == "V"


# -- CLI ------------------------------------------------------------------------------------------

def test_cli_emulate_and_export_know_the_model(tmp_path: Path) -> None:
    from blinkcan.cli.emulate import build_twins

    (twin,) = build_twins(("pkp-3500-mt",), None, None, "firmware")
    assert isinstance(twin, Pkp3500Twin)
    assert twin.node_id == 0x15
    result = CliRunner().invoke(cli, ["export", "eds", MT, "-o", str(tmp_path / "mt.eds")])
    assert result.exit_code == 0, result.output
    assert "PKP3500MT" in (tmp_path / "mt.eds").read_text()


def test_readme_pkp3500_twin_example_runs() -> None:
    import re

    readme = (Path(__file__).resolve().parents[2] / "README.md").read_text()
    section = readme[readme.index("### The PKP-3500-MT"):]
    code = re.search(r"```python\n(.*?)```", section, re.S)
    assert code is not None
    scope: dict[str, Any] = {}
    exec(compile(code.group(1), "README.md", "exec"), scope)
    assert scope["mt"].objects["digital_inputs"] == 0b101  # IN0 driven high, IN2 at 3 V


def test_scan_names_the_model() -> None:
    from blinkcan.host import scan

    with Rig() as rig:
        rig.add(mt_twin())
        rig.add(KeypadTwin(node_id=0x16))
        found = {f.node_id: (f.kind, f.model) for f in scan(rig.bus, listen=0.05)}
    assert found == {0x15: ("keypad", MT), 0x16: ("keypad", "pkp-2600-si")}


def test_asyncio_face_offers_encoder_events_and_ring_leds() -> None:
    import asyncio
    import uuid

    import can

    from blinkcan.host.pkp3500 import AsyncPkp3500Keypad
    from blinkcan.runtime import Emulator

    channel = f"mt-aio-{uuid.uuid4().hex}"
    device_bus, host_bus = (can.Bus(interface="virtual", channel=channel) for _ in range(2))
    twin = quiet(mt_twin())

    async def main() -> None:
        async with AsyncPkp3500Keypad(host_bus, 0x15) as keypad:
            await keypad.set_ring(2, [17, 18])
            events = keypad.encoder_events(timeout=2.0)
            await asyncio.sleep(0.1)
            emulator.run(lambda now: twin.turn(1, 2, now))  # type: ignore[attr-defined]
            first = await events.__anext__()
            assert (first.encoder, first.ticks, first.counter) == (1, 1, 1)
            assert await keypad.read_counter(1) == 2

    emulator = Emulator(device_bus, [twin])
    with emulator:
        asyncio.run(main())
        assert twin.objects["led_on_rings"] == 0x0003_0000
    device_bus.shutdown()
    host_bus.shutdown()


def test_monitor_draws_the_3_by_5_face_and_the_knobs_and_inputs(tmp_path: Path) -> None:
    from blinkcan.formats.logs import FrameWriter

    path = tmp_path / "mt.log"
    with FrameWriter(path) as writer:
        for timestamp, frame in enumerate((
                Frame(0x715, b"\x00"), Frame(0x000, b"\x01\x15"),
                Frame(0x215, bytes.fromhex("0400040000000000")),  # amber key-LED 3
                Frame(0x195, bytes.fromhex("0104000011")),  # keys 1 and 11 (the knobs) held
                Frame(0x295, bytes.fromhex("0103000800000000")),
                Frame(0x495, bytes.fromhex("F401C8002C016400")))):
            writer.write(float(timestamp), frame)
    result = CliRunner().invoke(cli, ["monitor", "--file", str(path), "--device",
                                      "0x15=pkp-3500-mt"],  # the picture, as a terminal has it
                                env={"COLUMNS": "160", "TTY_COMPATIBLE": "1", "NO_COLOR": "1"})
    assert result.exit_code == 0, result.output
    rows = [line for line in result.output.splitlines() if "[11" in line]
    assert rows  # MT §2: 11, 6, 1 on the top row
    assert "[ 6" in rows[0]
    assert "[ 1" in rows[0]
    assert "[ 3 yellow" in result.output
    assert "encoder 1 state: ticks since the last report 1, tick counter 3" in result.output
    assert "analog inputs: in0 5 V, in1 2 V, in2 3 V, in3 1 V" in result.output


def test_driver_takes_an_encoder_pdo_as_a_python_canopen_local_node_sends_it() -> None:
    """A LocalNode configured from our EDS sends 295h with the 4 bytes 1A01h maps (M42); the
    driver took only 8-byte frames (issue 17 item 10)."""
    import io

    import canopen

    from blinkcan.runtime.simbus import SimulatedBus

    sent: list[Frame] = []
    with Rig() as rig:
        keypad = Keypad(rig.bus, 0x15, model=MT, verify=False, start=False)
        assert isinstance(keypad, Pkp3500Keypad)
        events: list[EncoderEvent] = []
        keypad.on_encoder(events.append)
        network: Any = canopen.Network(SimulatedBus(rig.network, "local node"))
        network.connect()
        try:
            eds: Any = io.StringIO(eds_text(describe_device(MT)))
            eds.name = "pkp-3500-mt.eds"  # python-canopen tells the format by the name
            node: Any = canopen.LocalNode(0x15, eds)
            network.add_node(node)
            node.tpdo.read(from_od=True)
            encoder = node.tpdo[2]
            record = "Digital input module, keys states"
            encoder[f"{record}.Encoder 1 direction counter"].raw = 0x81  # 1 tick CCW (M37)
            encoder[f"{record}.Encoder 1 tick counter"].raw = 0xFFFE
            encoder[f"{record}.TOP position encoder 1"].raw = 0
            encoder.transmit()
            rig.settle()
            sent = [timed.frame for timed in rig.frames if timed.frame.can_id == 0x295]
        finally:
            network.disconnect()
    assert [len(frame.data) for frame in sent] == [4]
    assert [(e.encoder, e.ticks, e.counter, e.top) for e in events] == [(1, -1, 0xFFFE, 0)]
