"""Issue 17 item 8: ``blinkcan nmt`` reports only what a node says after the command."""

from __future__ import annotations

import uuid
from collections.abc import Iterator

import can
import pytest
from click.testing import CliRunner

import blinkcan.cli.nmt as nmt_cli
from blinkcan.cli.bus_options import cli_bus
from blinkcan.cli.main import cli
from blinkcan.protocol.nmt import NmtCommand, nmt_frame
from blinkcan.runtime import Emulator
from blinkcan.twin import KeypadTwin


@pytest.fixture
def channel() -> Iterator[str]:
    name = f"nmt-{uuid.uuid4().hex}"
    device_bus = can.Bus(interface="virtual", channel=name)
    keypad = KeypadTwin(node_id=0x15, settings={"producer_heartbeat_time": 100})
    with Emulator(device_bus, [keypad]) as emulator:
        # started before the command: every heartbeat it sends says operational, so that the
        # only other state on the bus is the one the test puts in flight (a heartbeat of its
        # own sent while the command was on its way would race the command on a loaded host)
        emulator.run(lambda now: keypad.receive(nmt_frame(NmtCommand.START, 0x15), now))
        assert emulator.snapshot(keypad)["nmt_state"] == "operational"
        yield name
    device_bus.shutdown()


def test_a_heartbeat_sent_before_the_command_is_not_its_answer(
        channel: str, monkeypatch: pytest.MonkeyPatch) -> None:
    opened = cli_bus

    def bus_with_a_heartbeat_in_flight() -> can.BusABC:
        bus = opened()
        other = can.Bus(interface="virtual", channel=channel)
        # the keypad's heartbeat "pre-operational", sent just before the command goes out
        other.send(can.Message(arbitration_id=0x715, data=b"\x7f", is_extended_id=False))
        other.shutdown()
        return bus

    monkeypatch.setattr(nmt_cli, "cli_bus", bus_with_a_heartbeat_in_flight)
    # 2 s: the keypad says its state every 0.1 s; a loaded host may hold its thread a while
    result = CliRunner().invoke(cli, ["nmt", "start", "all", "--listen", "2", "-i", "virtual",
                                      "-c", channel])
    assert result.exit_code == 0, result.output
    assert result.output.splitlines() == ["sent NMT start to every node",
                                          "node 15h: operational"]
