"""``record`` writes the channel the bus gave each frame, or, where the bus gives none
(udp_multicast) and the format names every frame's, the stated default (can0), saying so; a
round trip through ``convert`` keeps it. python-can's candump writer named such frames
``vcan0``, a channel no bus had, and converting the recording then reported it lost."""

from __future__ import annotations

import random
from pathlib import Path

import can
import pytest
from click.testing import CliRunner

from blinkcan.cli import convert
from blinkcan.cli.bus_options import cli_bus
from blinkcan.cli.main import cli
from blinkcan.formats.carried import CARRIES, DEFAULT_CHANNEL, channel_key
from blinkcan.formats.log_writers import WRITERS
from blinkcan.formats.logs import read_messages

FRAMES = 5
#: formats record writes that no reader reads back (python-can's Printer: for people)
WRITE_ONLY = {".txt", ".mf4"}  # .mf4: written only when closed, record refuses it
FORMATS = sorted({*WRITERS, ".pcap"} - WRITE_ONLY)


def _bus_options(kind: str) -> tuple[list[str], dict[str, object], str | None]:
    """The options naming a fresh bus of ``kind``, python-can's arguments for a second
    handle on it, and the channel a frame read from it carries (None: it carries none)."""
    if kind == "virtual":
        # digits at its end: python-can's numbered writers took them as its number (past
        # BLF's 16 bits: the recording failed)
        channel = f"bench-{random.randint(10**7, 10**8 - 1)}"
        return (["-i", "virtual", "-c", channel], {"interface": "virtual", "channel": channel},
                channel)
    group = f"239.74.{random.randint(1, 254)}.{random.randint(1, 254)}"
    port = random.randint(40000, 60000)
    return (["-i", "udp_multicast", "-c", group, "--bus-kwargs", f"port={port}", "hop_limit=0"],
            {"interface": "udp_multicast", "channel": group, "port": port, "hop_limit": 0},
            None)


def _record(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, kind: str, suffix: str
            ) -> tuple[Path, str, str | None]:
    """A recording of FRAMES frames sent on a ``kind`` bus right after record opened it."""
    options, sender_args, carried = _bus_options(kind)
    def open_then_send() -> can.BusABC:
        bus = cli_bus()  # as record opens it, from its options
        with can.Bus(**sender_args) as sender:  # type: ignore[arg-type]
            for number in range(FRAMES):
                sender.send(can.Message(arbitration_id=0x70C, data=[5, number],
                                        is_extended_id=False))
        return bus

    monkeypatch.setattr(convert, "cli_bus", open_then_send)
    target = tmp_path / f"recorded{suffix}"
    result = CliRunner().invoke(cli, ["record", str(target), "--duration", "0.5", *options])
    assert result.exit_code == 0, result.output
    assert f"{FRAMES} frames recorded" in result.stderr
    return target, result.stderr, carried


@pytest.mark.parametrize("suffix", FORMATS)
@pytest.mark.parametrize("kind", ["udp_multicast", "virtual"])
def test_record_writes_the_bus_channel_and_a_round_trip_keeps_it(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, kind: str, suffix: str) -> None:
    recording, said, carried = _record(tmp_path, monkeypatch, kind, suffix)
    keeps = CARRIES[suffix].channel
    channels = {channel_key(m.channel) for m in read_messages(recording)}
    if keeps == "none":
        assert channels == {None}
    elif carried is None:  # the stated default, said once
        assert channels == {DEFAULT_CHANNEL}
        assert f"{FRAMES} frames had no channel: {suffix} names every frame's, so they " \
               f"are on {DEFAULT_CHANNEL}" in said
    elif keeps == "name":
        assert channels == {carried}
    else:  # a numbered format cannot hold the virtual bus's name: said, on the default
        assert f"{FRAMES} frames lost their channel name ({carried})" in said
        assert channels == {DEFAULT_CHANNEL}
    # a round trip keeps what the recording holds, and loses nothing it does not say
    there, back = tmp_path / "there.log", tmp_path / f"back{suffix}"
    first = CliRunner().invoke(cli, ["convert", str(recording), str(there)])
    assert first.exit_code == 0, first.output
    assert " lost " not in first.stderr, first.stderr
    written = {channel_key(m.channel) for m in read_messages(there)}
    assert written == ({DEFAULT_CHANNEL} if channels == {None} else channels)
    second = CliRunner().invoke(cli, ["convert", str(there), str(back)])
    assert second.exit_code == 0, second.output
    if keeps != "none":
        assert " lost " not in second.stderr, second.stderr
        assert {channel_key(m.channel) for m in read_messages(back)} == channels

