"""decode, convert, export, record and scan on the command line."""

from __future__ import annotations

import json
import threading
import time
import uuid
from pathlib import Path

import can
import pytest
from click.testing import CliRunner

from blinkcan.cli.main import cli
from blinkcan.formats.logs import FrameWriter, read_frames
from blinkcan.runtime import Emulator
from blinkcan.twin import KeyboxTwin, KeypadTwin
from tests.cli.session import session

GOLDEN = Path(__file__).parent / "golden" / "session.txt"


@pytest.fixture
def candump(tmp_path: Path) -> Path:
    path = tmp_path / "session.log"
    with FrameWriter(path) as writer:
        for timestamp, frame in session():
            writer.write(1000.0 + timestamp, frame)
    return path


def test_decode_matches_the_golden_output(candump: Path) -> None:
    result = CliRunner().invoke(cli, ["decode", str(candump)])
    assert result.exit_code == 0, result.output
    assert result.stdout == GOLDEN.read_text()


def test_decode_json_is_one_object_per_frame(candump: Path) -> None:
    result = CliRunner().invoke(cli, ["decode", "--json", str(candump)])
    assert result.exit_code == 0, result.output
    lines = [json.loads(line) for line in result.stdout.splitlines()]
    assert len(lines) == len(session())
    faults = [line for line in lines if line.get("pdo") == "faults"]
    assert faults[0]["faults"] == [4]
    assert faults[0]["text"] == "keybox 0Ch: outputs in FAULT: 4"


def test_decode_learns_or_is_told_which_node_is_which(tmp_path: Path) -> None:
    path = tmp_path / "pdo.log"
    path.write_text("(1.0) can0 18C#0800000000000000\n(1.1) can0 18D#0800000000000000\n")
    told = CliRunner().invoke(cli, ["decode", str(path), "--device", "0x0D=keybox"])
    assert "keybox 0Dh: outputs in FAULT: 4" in told.stdout
    assert "node 0Ch: frame 18Ch" in told.stdout  # told: nothing assumed
    assert "assuming" not in told.stderr


def test_decode_assumes_the_default_nodes_and_says_so(tmp_path: Path) -> None:
    path = tmp_path / "pdo.log"
    path.write_text("(1.0) can0 18C#0800000000000000\n(1.1) can0 18D#0800000000000000\n")
    untold = CliRunner().invoke(cli, ["decode", str(path)])
    assert "keybox 0Ch: outputs in FAULT: 4" in untold.stdout
    assert "node 0Dh: frame 18Dh" in untold.stdout
    assert "assuming keybox 0Ch, keypad 15h" in untold.stderr


@pytest.mark.parametrize("suffix", [".pcap", ".asc", ".blf", ".csv"])
def test_convert_round_trips_through_other_formats(candump: Path, tmp_path: Path,
                                                   suffix: str) -> None:
    other, back = tmp_path / f"session{suffix}", tmp_path / "back.log"
    runner = CliRunner()
    assert runner.invoke(cli, ["convert", str(candump), str(other)]).exit_code == 0
    assert runner.invoke(cli, ["convert", str(other), str(back)]).exit_code == 0
    assert [f for _, f in read_frames(back)] == [f for _, f in read_frames(candump)]
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(  # no partial file left
        ["session.log", other.name, "back.log"])


def test_nothing_a_user_stored_is_replaced_without_force(candump: Path, tmp_path: Path) -> None:
    mine = tmp_path / "mine.pcap"
    mine.write_bytes(b"my capture")
    for args in (["convert", str(candump), str(mine)], ["export", "eds", "keypad", "-o",
                                                        str(mine)],
                 ["record", str(mine), "--duration", "0.1", "-i", "virtual"]):
        result = CliRunner().invoke(cli, args)
        assert result.exit_code != 0
        assert "exists; pass --force" in result.output
        assert mine.read_bytes() == b"my capture"
    assert CliRunner().invoke(cli, ["convert", str(candump), str(mine), "--force"]).exit_code == 0
    assert mine.read_bytes() != b"my capture"


def test_export_writes_files_other_tools_read(tmp_path: Path) -> None:
    eds, dbc = tmp_path / "keybox.eds", tmp_path / "keypad.dbc"
    runner = CliRunner()
    assert runner.invoke(cli, ["export", "eds", "keybox", "-o", str(eds)]).exit_code == 0
    assert runner.invoke(cli, ["export", "dbc", "keypad", "-o", str(dbc)]).exit_code == 0
    assert "[1016sub1]" in eds.read_text()
    assert "KEYPAD_15_LED_ON" in dbc.read_text()
    stdout = runner.invoke(cli, ["export", "eds", "keypad", "--manual", "1.1"])
    assert stdout.output.startswith("[FileInfo]")


def test_record_a_live_bus_to_pcap(tmp_path: Path) -> None:
    channel = f"record-{uuid.uuid4().hex}"
    device_bus = can.Bus(interface="virtual", channel=channel)
    target = tmp_path / "live.pcap"
    twin = KeypadTwin()
    emulator = Emulator(device_bus, [twin])

    def later() -> None:
        time.sleep(0.3)
        emulator.start()

    starter = threading.Thread(target=later)
    starter.start()
    result = CliRunner().invoke(cli, ["record", str(target), "--duration", "0.8",
                                      "-i", "virtual", "-c", channel])
    starter.join()
    emulator.stop()
    device_bus.shutdown()
    assert result.exit_code == 0, result.output
    assert [f.can_id for _, f in read_frames(target)][:1] == [0x715]


def test_scan_lists_the_devices() -> None:
    channel = f"scan-cli-{uuid.uuid4().hex}"
    device_bus = can.Bus(interface="virtual", channel=channel)
    try:
        with Emulator(device_bus, [KeypadTwin(), KeyboxTwin()]):
            result = CliRunner().invoke(cli, ["scan", "--listen", "0.05", "-i", "virtual",
                                              "-c", channel], env={"COLUMNS": "150"})
    finally:
        device_bus.shutdown()
    assert result.exit_code == 0, result.output
    assert "keybox" in result.output  # the registered models (what --model takes)
    assert "pkp-2600-si" in result.output
    assert "V2.2" in result.output


@pytest.mark.parametrize(("args", "message"), [
    (["decode", "missing.log"], "no such file: missing.log"),
    (["decode", "x.log", "--device", "0x15"], "write NODE=MODEL"),
    (["decode", "x.log", "--device", "0x15=toaster"], "unknown device 'toaster'"),
    (["convert", "missing.log", "out.pcap"], "no such file"),
    (["export", "dbc", "toaster"], "unknown device"),
    (["export", "eds", "keybox", "--manual", "1.1"], "keybox generations are 1.0"),
    (["scan", "-i", "no-such-interface"], "cannot open the bus"),
])
def test_mistakes_are_one_clear_line(args: list[str], message: str, tmp_path: Path,
                                     monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    (tmp_path / "x.log").write_text("(1.0) can0 715#00\n")
    result = CliRunner().invoke(cli, args)
    assert result.exit_code != 0
    assert message in result.output
    assert "Traceback" not in result.output


def test_a_failed_conversion_leaves_no_file(tmp_path: Path) -> None:
    broken = tmp_path / "broken.pcap"
    broken.write_bytes(b"\xd4\xc3\xb2\xa1" + bytes(20) + b"\x01")  # header, then garbage
    target = tmp_path / "out.asc"
    result = CliRunner().invoke(cli, ["convert", str(broken), str(target)])
    assert result.exit_code == 1
    assert "not SocketCAN" in result.output
    assert "Traceback" not in result.output
    assert sorted(p.name for p in tmp_path.iterdir()) == ["broken.pcap"]
    decoded = CliRunner().invoke(cli, ["decode", str(broken)])
    assert decoded.exit_code == 1
    assert "not SocketCAN" in decoded.output
