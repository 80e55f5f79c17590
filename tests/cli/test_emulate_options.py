"""``blinkcan emulate``'s options are checked before the bus opens, and an option applies to
the devices that have it: --protocol j1939 runs a J1939 keypad beside a CANopen Keybox,
--low-side with no Keybox and a non-finite --response-delay are usage errors (found by the
newcomer/attacker pass of session 4)."""

from __future__ import annotations

import pytest
from click.testing import CliRunner

from blinkcan.cli.emulate import build_twins
from blinkcan.cli.main import cli
from blinkcan.devices.registry import models

# an interface python-can does not know: reaching the bus would be another error
NO_BUS = ["-i", "no-such-interface"]


@pytest.mark.parametrize("value", ["nan", "inf", "1e400", "-1"])
def test_a_bad_response_delay_is_a_usage_error_before_the_bus(value: str) -> None:
    result = CliRunner().invoke(cli, ["emulate", "keypad", "--response-delay", value, *NO_BUS])
    assert result.exit_code == 2, result.output
    assert "--response-delay" in result.output
    assert "no-such-interface" not in result.output


def test_low_side_pins_without_a_device_that_has_them_is_a_usage_error() -> None:
    result = CliRunner().invoke(cli, ["emulate", "keypad", "--low-side", "2,5", *NO_BUS])
    assert result.exit_code == 2, result.output
    having = [m.description().title for m in models()
              if m.description().face.low_side_capable]
    assert f"--low-side applies to {', '.join(having)} only" in result.output


@pytest.mark.parametrize("protocol", sorted({f for m in models()
                                             for f in m.description().features
                                             if f == "j1939"}))
def test_a_protocol_applies_to_the_devices_that_have_it(protocol: str) -> None:
    everything = [m.name for m in models()]
    twins = build_twins(tuple(f"{name}:{n + 0x10:#x}" for n, name in enumerate(everything)),
                        None, None, "firmware", (), protocol)
    try:
        running = {twin.description.model: getattr(twin, "protocol", "canopen")
                   for twin in twins}
        for model in models():
            expected = protocol if protocol in model.description().features else "canopen"
            assert running[model.description().model] == expected
    finally:
        for twin in twins:
            twin.close()
    without = [m.name for m in models() if protocol not in m.description().features]
    refused = CliRunner().invoke(cli, ["emulate", *without, "--protocol", protocol, *NO_BUS])
    assert refused.exit_code == 2, refused.output
    assert f"--protocol {protocol} applies to" in refused.output


def test_a_j1939_keypad_claims_the_address_its_device_names() -> None:
    # DEVICE:ADDR in J1939 mode is the source address (§16), as --address is for `keypad`;
    # it was ignored (every emulated J1939 keypad sat at 21h; found by the attack pass)
    j1939 = [m.name for m in models() if "j1939" in m.description().features]
    twins = build_twins(tuple(f"{name}:{0x30 + n:#x}" for n, name in enumerate(j1939)),
                        None, None, "firmware", (), "j1939")
    try:
        for n, twin in enumerate(twins):
            twin.power_on(0.0)
            twin.advance(1.0)
            assert twin.snapshot()["j1939"]["source_address"] == 0x30 + n
    finally:
        for twin in twins:
            twin.close()
