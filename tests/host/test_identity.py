"""A driver confirms which device is at its node id before its first command (issue #10 item 4)."""

from __future__ import annotations

import pytest
from click.testing import CliRunner

from blinkcan.cli.main import cli
from blinkcan.host import Keybox, Keypad, NoDeviceError, WrongDeviceError
from tests.host.conftest import Rig


def test_a_keypad_driver_refuses_a_keybox(rig: Rig) -> None:
    rig.sniffed()
    with pytest.raises(WrongDeviceError, match=r"^node 0Ch is a Keybox, not a PKP-2600-SI "
                                               r"keypad"):
        Keypad(rig.host, node_id=0x0C)
    sent = [f for f in rig.sniffed() if f.can_id < 0x580 or f.can_id > 0x67F]
    assert sent == []  # nothing but the SDO reads of the identity: no NMT start, no LED PDO


def test_a_keybox_driver_refuses_a_keypad(rig: Rig) -> None:
    with pytest.raises(WrongDeviceError, match=r"^node 15h is a PKP-2600-SI keypad, not a "
                                               r"Keybox"):
        Keybox(rig.host, node_id=0x15)


def test_a_driver_with_nothing_at_its_node_id_says_so(rig: Rig) -> None:
    with pytest.raises(NoDeviceError, match=r"no device answers at node 22h"):
        Keybox(rig.host, node_id=0x22, sdo_timeout=0.05)


def test_verify_false_drives_a_device_that_cannot_answer_sdo(rig: Rig) -> None:
    rig.sniffed()
    keypad = Keypad(rig.host, node_id=0x22, generation="1.1", verify=False)
    keypad.set_led(1, "blue")
    assert [f.can_id for f in rig.sniffed()] == [0x000, 0x222, 0x322]  # start, LED PDOs


def test_the_generation_property_never_reads_the_device(rig: Rig) -> None:
    keypad = Keypad(rig.host, node_id=0x22, verify=False, start=False)
    rig.sniffed()
    assert keypad.generation is None  # unknown: no SDO read (issue 19)
    assert rig.sniffed() == []


def test_the_right_device_is_accepted(rig: Rig) -> None:
    assert Keypad(rig.host).identity().model_id == "PKP2600SI"
    assert Keybox(rig.host).identity().model_id == "Keybox3"


@pytest.mark.parametrize(("args", "message"), [
    (["keypad", "--node-id", "0x0C", "led", "1", "blue"],
     "node 0Ch is a Keybox, not a PKP-2600-SI keypad"),
    (["keybox", "--node-id", "0x15", "info"], "node 15h is a PKP-2600-SI keypad, not a Keybox"),
    (["keypad", "--node-id", "0x22", "brightness", "10"], "no device answers at node 22h"),
])
def test_cli_commands_confirm_the_device_first(rig: Rig, args: list[str], message: str) -> None:
    channel = rig.channel
    before = rig.emulator.snapshot(rig.keybox)["pins"]
    result = CliRunner().invoke(cli, [args[0], "-i", "virtual", "-c", channel, *args[1:]])
    assert result.exit_code != 0
    assert message in result.output
    assert len(result.output.strip().splitlines()) == 1
    assert rig.emulator.snapshot(rig.keybox)["pins"] == before  # pin 9 was not switched HIGH
