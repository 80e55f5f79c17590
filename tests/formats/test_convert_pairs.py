"""``convert`` between every pair of formats keeps each frame or says what it lost (issue 18
item 3): a log holding every kind of frame goes from each format to each other one, and every
frame read back is compared with the frame converted, field by field. Whatever differs must
have been announced, with the number of frames it happened to; whatever was announced must
have happened."""

from __future__ import annotations

import importlib.util
import re
from collections import Counter
from itertools import pairwise, product
from pathlib import Path

import can
import pytest
from click.testing import CliRunner

from blinkcan.cli.main import cli
from blinkcan.formats.carried import CARRIES
from blinkcan.formats.logs import frame_kind, read_messages

FORMATS = [".log", ".pcap", ".asc", ".blf", ".csv", ".db", ".trc", ".mf4"]

#: every kind of frame: 11/29-bit data, remote with and without a DLC, an error frame with its
#: class and data, CAN FD with BRS and ESI from 0 to 64 bytes (8 bytes: FD only by its flag),
#: several channels (vcan2: a name a numbered format cannot keep), absolute times with
#: microseconds, one frame earlier than the one before and one earlier than the first
EVERY_KIND = "\n".join([
    "(1700000000.123456) can0 715#05 R",
    "(1700000000.223457) can1 18FF0015#0001020304050607 R",
    "(1700000000.323458) can0 70C#R3 R",
    "(1700000000.423459) can1 01ABCDEF#R T",
    "(1700000000.523460) can0 20000004#0004000000000000",
    "(1700000000.623461) can1 123##1" + bytes(range(12)).hex().upper() + " R",
    "(1700000000.723462) can0 01234567##2" + bytes(range(64)).hex().upper() + " R",
    "(1700000000.823463) can0 124##3 R",
    "(1700000000.923464) can1 125##1" + bytes(range(8)).hex().upper() + " R",
    "(1700000001.023465) can0 001# R",
    "(1700000001.123466) vcan2 222#0102 R",
    "(1700000001.223467) can1 7FF#0102030405060708 T",
    "(1700000001.200000) can0 1FFFFFFF#AA R",
    "(1700000000.100000) can0 100#01 R",
]) + "\n"

#: how convert names each loss (its line: "N frames lost <label> (...): <why>")
LABELS = {
    "their channel": "channel",
    "their channel name": "channel name",
    "the CAN FD flag": "fd flag",
    "the bit rate switch": "brs",
    "the error state indicator": "esi",
    "their error class and data": "error details",
    "their time": "time",
}
TIME_RESOLUTION = 1.5e-6  # every format keeps microseconds (rounding may move the last digit)


def _is_error_line(line: str) -> bool:
    """A candump line of an error frame: 8 identifier digits with CAN_ERR_FLAG."""
    ident = line.split()[2].partition("#")[0]
    return len(ident) == 8 and bool(int(ident, 16) & 0x20000000)


def _available(suffix: str) -> bool:
    return suffix != ".mf4" or importlib.util.find_spec("asammdf") is not None


@pytest.fixture(scope="module")
def sources(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """The every-kind log in each format (what that format keeps of it)."""
    folder = tmp_path_factory.mktemp("sources")
    original = folder / "every.log"
    original.write_text(EVERY_KIND)
    # .trc cannot carry error frames (convert refuses them): it is made without them
    without_errors = folder / "no-errors.log"
    without_errors.write_text("".join(f"{line}\n" for line in EVERY_KIND.splitlines()
                                      if not _is_error_line(line)))
    made = {".log": original}
    for suffix in FORMATS:
        if suffix != ".log" and _available(suffix):
            made[suffix] = folder / f"every{suffix}"
            source = without_errors if suffix == ".trc" else original
            result = CliRunner().invoke(cli, ["convert", str(source), str(made[suffix])])
            assert result.exit_code == 0, result.output
    return made


def _key(message: can.Message) -> tuple[bool, int]:
    return (True, 0) if message.is_error_frame else (False, message.arbitration_id)


def _channel(message: can.Message) -> str | None:
    channel = message.channel
    if isinstance(channel, int) or (isinstance(channel, str) and channel.isdigit()):
        return f"can{int(channel)}"
    return None if channel is None else str(channel)


def _differences(before: can.Message, after: can.Message) -> list[str]:
    """What of ``before`` is not in ``after``; AssertionError for what must never change."""
    changed = []
    assert after.is_error_frame == before.is_error_frame
    if before.is_error_frame:
        if (after.arbitration_id, bytes(after.data)) != (before.arbitration_id,
                                                         bytes(before.data)):
            changed.append("error details")
    else:
        assert (after.arbitration_id, after.is_extended_id, after.is_remote_frame) == (
            before.arbitration_id, before.is_extended_id, before.is_remote_frame)
        if before.is_remote_frame:
            assert after.dlc == before.dlc
        else:
            assert bytes(after.data) == bytes(before.data)
        if after.is_fd != before.is_fd:
            changed.append("fd flag")
        if after.bitrate_switch != before.bitrate_switch:
            changed.append("brs")
        if after.error_state_indicator != before.error_state_indicator:
            changed.append("esi")
    if _channel(before) is not None and _channel(after) != _channel(before):
        changed.append("channel" if _channel(after) is None else "channel name")
    if abs(after.timestamp - before.timestamp) > TIME_RESOLUTION:
        changed.append("time")
    return changed


def _announced(output: str) -> Counter[str]:
    announced: Counter[str] = Counter()
    for count, label in re.findall(r"^(\d+) frames? lost (.+?) \(", output, re.MULTILINE):
        announced[LABELS[label.replace("its ", "their ", 1)]] += int(count)
    return announced


@pytest.mark.parametrize(("source_suffix", "target_suffix"), list(product(FORMATS, FORMATS)))
def test_every_pair_keeps_each_frame_or_says_what_it_lost(
        sources: dict[str, Path], tmp_path: Path, source_suffix: str,
        target_suffix: str) -> None:
    if not (_available(source_suffix) and _available(target_suffix)):
        pytest.skip("MF4 needs asammdf")
    source = sources[source_suffix]
    target = tmp_path / f"out{target_suffix}"
    result = CliRunner().invoke(cli, ["convert", str(source), str(target)])
    before = list(read_messages(source))
    refused = Counter(kind for message in before if (kind := frame_kind(message))
                      in CARRIES[target_suffix].dropped)
    if refused:  # a frame the target cannot hold refuses the conversion: nothing written
        assert result.exit_code == 1, result.output
        total = sum(refused.values())
        kinds = ", ".join(f"{n} {kind}" for kind, n in sorted(refused.items()))
        assert f"Error: {source} holds {total} frame{'s' if total != 1 else ''} " \
               f"{target_suffix} cannot carry ({kinds}: " in result.output
        assert not target.exists()
        assert not list(tmp_path.iterdir())
        return
    assert result.exit_code == 0, result.output
    after = list(read_messages(target))
    assert f"{len(after)} frames written" in result.output

    not_written: Counter[str] = Counter()
    changed: Counter[str] = Counter()
    remaining = iter(after)
    following = next(remaining, None)
    for message in before:  # the frames read back are the frames written, in their order
        if following is not None and _key(following) == _key(message):
            changed.update(_differences(message, following))
            following = next(remaining, None)
        else:
            not_written[frame_kind(message)] += 1
    assert following is None, f"a frame that was not converted: {following}"
    assert not not_written, f"frames lost: {not_written}"
    assert _announced(result.output) == changed, result.output


@pytest.mark.parametrize("suffix", [s for s in FORMATS if s != ".log"])
def test_times_near_zero_survive_every_format(tmp_path: Path, suffix: str) -> None:
    """A log timed from 0 (not from 1970), as many tools write them."""
    if not _available(suffix):
        pytest.skip("MF4 needs asammdf")
    source = tmp_path / "relative.log"
    source.write_text("(0.500000) can0 715#05 R\n(1.250001) can1 70C#R2 R\n"
                      "(2.000002) can0 7FF#0102 R\n")
    target = tmp_path / f"relative{suffix}"
    assert CliRunner().invoke(cli, ["convert", str(source), str(target)]).exit_code == 0
    times = [m.timestamp for m in read_messages(target) if not m.is_remote_frame]
    assert times == pytest.approx([0.5, 2.000002], abs=TIME_RESOLUTION)


def test_the_readme_example_is_what_convert_says(tmp_path: Path,
                                                 monkeypatch: pytest.MonkeyPatch) -> None:
    readme = (Path(__file__).resolve().parents[2] / "README.md").read_text()
    section = readme.split("## Lossless captures", 1)[1].split("\n## ", 1)[0]
    example = re.search(r"```\n\$ (blinkcan convert .*?)\n(.*?)```", section, re.S)
    assert example is not None
    monkeypatch.chdir(tmp_path)
    Path("trace.log").write_text("(1.000000) can0 123##1AABBCCDDEEFF0011 R\n"
                                 "(2.000000) can0 715#05 R\n")
    result = CliRunner().invoke(cli, example[1].split()[1:])
    assert result.exit_code == 0
    assert result.output == example[2]


def test_a_can_fd_frame_through_csv_and_blf_keeps_its_bytes_and_asc_its_time(
        tmp_path: Path) -> None:
    """The issue's cases: ``.log -> .csv -> .blf -> .log`` cut a 12-byte CAN FD frame to 8
    bytes and said nothing; through ``.asc`` absolute times became 0.000000."""
    source = tmp_path / "fd.log"
    source.write_text("(1700000000.250000) can0 123##1" + bytes(range(12)).hex().upper()
                      + " R\n")
    chain = [source, tmp_path / "fd.csv", tmp_path / "fd.blf", tmp_path / "back.log"]
    outputs = []
    for before, after in pairwise(chain):
        result = CliRunner().invoke(cli, ["convert", str(before), str(after)])
        assert result.exit_code == 0, result.output
        outputs.append(result.output)
    assert "1 frame lost the bit rate switch (CAN FD frame 123h): .csv has no BRS flag" in \
        outputs[0]
    assert chain[-1].read_text() == ("(1700000000.250000) can0 123##0"
                                     + bytes(range(12)).hex().upper() + " R\n")
    via_asc = tmp_path / "fd.asc"
    assert CliRunner().invoke(cli, ["convert", str(source), str(via_asc)]).exit_code == 0
    assert [m.timestamp for m in read_messages(via_asc)] == [1700000000.25]
