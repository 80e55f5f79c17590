"""``blinkcan export dbc keypad --protocol j1939 --node-id 0x30`` wrote the DBC of address 21h
and said nothing: --node-id was ignored over J1939. A keypad in J1939 mode is at its address,
and --node-id says it (as ``emulate keypad:0x30 --protocol j1939`` and ``keypad --protocol
j1939 --node-id 0x30`` take it); a different --address beside it, and a generation named
twice (``keypad@1.5 --manual 1.1``, which said "not '1.5@1.1'"), are one line, exit 2."""

from __future__ import annotations

from typing import Any

import cantools
from click.testing import CliRunner

from blinkcan.cli.main import cli


def _frame_ids(args: list[str]) -> set[int]:
    result = CliRunner().invoke(cli, ["export", "dbc", "keypad", "--protocol", "j1939", *args,
                                      "-o", "-"])
    assert result.exit_code == 0, result.output
    database: Any = cantools.database.load_string(result.stdout, "dbc")
    return {message.frame_id for message in database.messages}


def test_node_id_is_the_j1939_address() -> None:
    at_30 = _frame_ids(["--address", "0x30"])
    assert _frame_ids(["--node-id", "0x30"]) == at_30
    assert _frame_ids(["--node-id", "0x30", "--address", "0x30"]) == at_30
    assert at_30 != _frame_ids([])


def test_node_id_and_another_address_are_refused() -> None:
    result = CliRunner().invoke(cli, ["export", "dbc", "keypad", "--protocol", "j1939",
                                      "--node-id", "0x30", "--address", "0x21", "-o", "-"])
    assert result.exit_code == 2
    assert "a J1939 DBC is for one address: --node-id 30h or --address 21h" in result.output


def test_a_generation_named_twice_is_refused() -> None:
    result = CliRunner().invoke(cli, ["export", "eds", "keypad@1.5", "--manual", "1.1", "-o",
                                      "-"])
    assert result.exit_code == 2
    assert "keypad@1.5 names its generation and --manual 1.1 another" in result.output
