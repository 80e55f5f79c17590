"""``decode --json`` a block at a time writes what decoding frame by frame writes.

The block writer (cli/decode.py) takes another ECU's frame's line around its time and data
from the decoder (Decoder.raw_json) and the block's times from one orjson call
(decoder.json_times). Logs mixing the devices' frames, identity traffic that names a node
mid-log (its raw lines must stop), other ECUs' 11- and 29-bit frames, odd lines and times
outside orjson's plain range give the same bytes as :meth:`Decoder.json_line` over
:func:`read_log`.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

from click.testing import CliRunner
from hypothesis import given, settings
from hypothesis import strategies as st

from blinkcan.cli.main import cli
from blinkcan.decode import Decoder
from blinkcan.decode.decoder import encode_json, json_time, json_times
from blinkcan.formats.logs import read_log
from blinkcan.formats.unreadable import UnreadableLine
from blinkcan.protocol import Frame

_FRAMES = [
    "715#05", "70C#7F", "71A#00", "195#0100000000", "18C#0800000000000000", "20C#0100",
    "215#0102030000000000", "000#0115", "080#",
    # node 1Ah named from identity traffic mid-log: its frames were another ECU's before
    "61A#4000100000000000", "59A#4300100091010B00", "19A#0100000000", "19A#0200000000",
    "60C#4000100000000000", "58C#4300100091010300",
    "123#DEADBEEF", "1FF#", "7E8#0102030405060708", "18FEF100#FFFFFFFFFFFFFFFF",
    "0CF00400#F07D7D0000F0FFFF", "18EFFF21#0102030405060708", "18EF2100#0A0B",
    "715#R", "715##1AABB", "20000004#0000000000000000", "715#123", "715#0",
]


def _line(time: float, frame: str) -> str:
    return f"({time:.6f}) can0 {frame}"


_lines = st.lists(st.one_of(
    st.builds(_line, st.floats(1.7e9, 1.7e9 + 100), st.sampled_from(_FRAMES)),
    st.builds(_line, st.sampled_from([0.0, 0.000001, 0.5, 1e16, 3e16]),
              st.sampled_from(_FRAMES)),
    st.sampled_from(["# comment", "", "not a frame"])), min_size=1, max_size=60)


def _frame_by_frame(path: Path, devices: dict[int, str]) -> str:
    decoder = Decoder(dict(devices.items()))
    lines = []
    for time, item in read_log(path):
        if isinstance(item, Frame):
            lines.append(decoder.json_line(item, time))
        elif isinstance(item, UnreadableLine):
            lines.append(encode_json(item.to_json()))
        else:  # the CLI's own events for remote, error and CAN FD frames
            from blinkcan.cli.decode import other_event

            lines.append(encode_json(other_event(decoder, item).to_json()))
    return "".join(line + "\n" for line in lines)


@settings(max_examples=60, deadline=None)
@given(_lines)
def test_decode_json_writes_what_json_line_writes(lines: list[str]) -> None:
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "bus.log"
        path.write_text("\n".join(lines) + "\n")
        if not any(line.startswith("(") and "#" in line for line in lines):
            return  # no frame: not a candump log (an error, the same either way)
        try:
            expected = _frame_by_frame(path, {0x15: "keypad", 0x0C: "keybox"})
        except ValueError:
            return  # no line is a frame
        result = CliRunner().invoke(cli, ["decode", "--json", "--device", "0x15=keypad",
                                          "--device", "0x0C=keybox", str(path)])
        assert result.exit_code == 0, result.output
        assert result.stdout == expected


def test_a_node_named_mid_block_has_its_frames_decoded_from_then_on(tmp_path: Path) -> None:
    path = tmp_path / "named.log"
    path.write_text("".join(f"{_line(1.7e9 + n, frame)}\n" for n, frame in enumerate([
        "19A#0100000000", "19A#0100000000", "61A#4000100000000000", "59A#4300100091010B00",
        "19A#0100000000", "19A#0000000000"])))
    result = CliRunner().invoke(cli, ["decode", "--json", str(path)])
    assert result.stdout == _frame_by_frame(path, {0x15: "keypad", 0x0C: "keybox"})
    assert '"kind":"frame"' in result.stdout.splitlines()[1]
    assert '"kind":"pdo"' in result.stdout.splitlines()[4]


def test_json_times_are_each_times_json_time() -> None:
    for times in ([1.7e9, 1.7e9 + 0.0005, 2.5], [0.0, 1.0], [1e-6, 3.0], [1e16, 2.0], [],
                  [1700000000.123456, 0.1 + 0.2]):
        assert json_times(times) == [json_time(time) for time in times]


def test_raw_json_is_the_line_around_time_and_data_until_the_node_is_named() -> None:
    decoder = Decoder({0x15: "keypad"})
    assert decoder.raw_json(0x19A, False) is None  # not seen yet
    foreign = Frame(0x18FEF100, bytes(8), True)
    for frame in (Frame(0x19A, b"\x01\x00\x00\x00\x00"), foreign):
        line = decoder.json_line(frame, 2.5)
        first, second = decoder.raw_json(frame.can_id, frame.extended) or ("?", "?")
        assert line == '{"time":2.5' + first + frame.data.hex() + second
    for text in ("61A 40 00 10 00 00 00 00 00", "59A 43 00 10 00 91 01 0B 00"):
        can_id, *data = text.split()
        decoder.json_line(Frame(int(can_id, 16), bytes.fromhex("".join(data))), 3.0)
    assert decoder.device(0x1A) is not None
    assert decoder.raw_json(0x19A, False) is None  # a keypad's key state now
    assert decoder.raw_json(0x18FEF100, True) is not None
