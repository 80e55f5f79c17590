"""``decode --json`` writes a time one way on every line, whichever path made the line (the
event's JSON, a cached body, a frame no device sends, an unreadable line, a remote frame): a
plain decimal (what people grep; ``0.00002``, never ``2e-05``) of the shortest digits that
read back as the same float."""

from __future__ import annotations

import json
import re
from pathlib import Path

import can
from click.testing import CliRunner
from hypothesis import given, settings
from hypothesis import strategies as st

from blinkcan.cli.decode import other_event
from blinkcan.cli.main import cli
from blinkcan.decode import Decoder
from blinkcan.decode.decoder import encode_json
from blinkcan.formats.unreadable import UnreadableLine
from blinkcan.protocol import Frame

_TIME = re.compile(r'^\{"time":([^,]*),')
_TIMES = st.one_of(*(st.floats(low, high, allow_nan=False, allow_infinity=False)
                     for low, high in ((1e-6, 1e-4), (0, 1e-3), (0, 4e9), (-1e3, 0),
                                       (1e-12, 1e-6), (1e15, 1e17))),
                   st.sampled_from([2e-5, 1e-5, 9.99e-6, 1e-4, 0.0, -0.0, 1e16]))
#: each twice: the first line is the event's JSON, the second a cached one
_FRAMES = [Frame(0x715, b"\x05"), Frame(0x123, b"\x01"), Frame(0x18FEF100, bytes(8), True),
           Frame(0x195, bytes(5)), Frame(0x70C, b"\x7f"), Frame(0x595, bytes.fromhex(
               "4018100000000000"))]


def _time_text(line: str) -> str:
    match = _TIME.match(line)
    assert match is not None, line
    return match.group(1)


@settings(max_examples=300, deadline=None)
@given(_TIMES)
def test_every_json_line_writes_its_time_the_same_way(time: float) -> None:
    decoder = Decoder({0x15: "keypad", 0x0C: "keybox"})
    lines = [decoder.json_line(frame, time) for frame in _FRAMES for _ in range(2)]
    lines.append(encode_json(UnreadableLine(3, "garbage", "'garbage' is bad", time).to_json()))
    remote = can.Message(timestamp=time, arbitration_id=0x70C, is_remote_frame=True)
    lines.append(encode_json(other_event(decoder, remote).to_json()))
    texts = {_time_text(line) for line in lines}
    assert len(texts) == 1, texts
    [text] = texts
    assert re.fullmatch(r"-?\d+\.\d+", text), text  # a plain decimal, no exponent
    assert float(text) == time
    for line in lines:
        assert json.loads(line)["time"] == time


def test_decode_json_writes_small_times_as_plain_decimals(tmp_path: Path) -> None:
    log = tmp_path / "start.log"
    log.write_text("(0.000020) can0 715#05\n(0.000020) can0 715#05\n(0.000030) can0 70C#R\n"
                   "(0.000040) can0 garbage\n(0.000050) can0 123#01\n(0.000050) can0 123#01\n")
    result = CliRunner().invoke(cli, ["decode", "--json", str(log)])
    assert result.exit_code == 0, result.output
    assert [_time_text(line) for line in result.stdout.splitlines()] == [
        "0.00002", "0.00002", "0.00003", "0.00004", "0.00005", "0.00005"]
