"""``blinkcan emulate``'s options are checked before the bus opens, and an option applies to
the devices that have it: --protocol j1939 runs a J1939 keypad beside a CANopen Keybox,
--low-side with no Keybox and a non-finite --response-delay are usage errors (found by the
newcomer/attacker pass of session 4)."""

from __future__ import annotations

import pytest
from click.testing import CliRunner

from blinkcan.cli.emulate import build_twins, decoder_devices, device_protocols
from blinkcan.cli.main import cli
from blinkcan.cli.typed_commands import TypedCommands
from blinkcan.decode import Decoder
from blinkcan.devices.registry import models
from blinkcan.runtime.simbus import SimulatedBus
from blinkcan.testing import Rig
from blinkcan.twin import KeypadTwin

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


# -- the attack pass of session 5 -------------------------------------------------------------

J1939_MODELS = [m.name for m in models() if "j1939" in m.description().features]


@pytest.mark.parametrize("model", J1939_MODELS)
def test_two_j1939_keypads_at_one_address_are_refused(model: str) -> None:
    # a J1939 keypad with no ADDR claims 21h (§5): `keypad keypad:0x21 --protocol j1939` was
    # two keypads on one address, both emulated (their node ids differed)
    result = CliRunner().invoke(cli, ["emulate", model, f"{model}:0x21", "--protocol", "j1939",
                                      *NO_BUS])
    assert result.exit_code == 2, result.output
    assert "both on J1939 address 21h" in result.output
    assert "no-such-interface" not in result.output


@pytest.mark.parametrize("model", J1939_MODELS)
@pytest.mark.parametrize("address", [0x80, 0xEE, 0xFD])
def test_a_j1939_keypad_claims_any_node_address(model: str, address: int) -> None:
    # J1939 node addresses are 01h..FDh (spec §16, as `keypad --address` takes them); DEVICE:ADDR
    # refused 80h and over as "node id outside 0x01..0x7f"
    [twin] = build_twins((f"{model}:{address:#x}",), None, None, "firmware", (), "j1939")
    try:
        twin.power_on(0.0)
        twin.advance(1.0)
        assert twin.snapshot()["j1939"]["source_address"] == address
    finally:
        twin.close()


@pytest.mark.parametrize("model", J1939_MODELS)
@pytest.mark.parametrize("address", ["0xFE", "0xFF", "0", "0x100"])
def test_a_j1939_address_outside_the_range_is_a_usage_error(model: str, address: str) -> None:
    result = CliRunner().invoke(cli, ["emulate", f"{model}:{address}", "--protocol", "j1939",
                                      *NO_BUS])
    assert result.exit_code == 2, result.output
    assert "J1939 address" in result.output
    assert "outside" in result.output


@pytest.mark.parametrize("address", ["127.0.0.1:99999", "abc", "127.0.0.1:-1"])
def test_a_bad_web_address_is_a_usage_error_before_the_bus(address: str) -> None:
    # it was checked after the bus opened and the devices had booted
    result = CliRunner().invoke(cli, ["emulate", "keypad", "--web", address, *NO_BUS])
    assert result.exit_code == 2, result.output
    assert "--web" in result.output
    assert "no-such-interface" not in result.output
    assert "emulating" not in result.output


@pytest.mark.parametrize("model", J1939_MODELS)
@pytest.mark.parametrize("address", [0x30, 0x90])
def test_the_frames_of_a_j1939_keypad_are_printed_with_their_meaning(model: str,
                                                                      address: int) -> None:
    # emulate's printer knew only 21h: a keypad at 30h printed its key messages as "keypad FFh:
    # malformed command (the keypad ignores it)"
    twins = build_twins((f"{model}:{address:#x}",), None, None, "firmware", (), "j1939")
    try:
        decoder = Decoder(decoder_devices(twins))
        [twin] = twins
        assert isinstance(twin, KeypadTwin)
        twin.power_on(0.0)
        [*frames] = twin.press(3, 0.5)
        assert frames
        assert str(decoder.decode(frames[-1], 0.5)).endswith(f"keypad {address:02X}h: key 3 "
                                                              "pressed")
    finally:
        for twin in twins:
            twin.close()


def test_an_address_two_j1939_keypads_share_as_node_id_names_them_both() -> None:
    # both keep the CANopen node id 15h (their J1939 addresses are 80h and 90h): '15h' is
    # ambiguous, and the error listed every device instead of the two it names
    twins = build_twins(("keypad:0x80", "keypad:0x90", "keybox"), None, None, "firmware", (),
                        "j1939")
    with Rig() as rig:
        for twin in twins:
            rig.add(twin)
        [answer] = TypedCommands(rig.emulator).execute("15h press 3")
    assert answer.startswith("Error: '15h' names 2 devices (PKP-2600-SI keypad 80h (J1939), "
                             "PKP-2600-SI keypad 90h (J1939)); start with the address")


# -- a protocol per device (session 7) ----------------------------------------------------------

#: every (model, mode) the registry has besides CANopen: a device spec can name each
PROTOCOL_MODES = [(m.name, p) for m in models() for p in device_protocols()
                  if p != "canopen" and p in m.description().features]


@pytest.mark.parametrize(("model", "protocol"), PROTOCOL_MODES)
@pytest.mark.parametrize("default", ["canopen", "other"])
def test_one_emulator_runs_each_device_in_the_protocol_it_names(
        model: str, protocol: str, default: str, monkeypatch: pytest.MonkeyPatch) -> None:
    # --protocol applied to the whole run: a CANopen and a J1939 PKP-2600-SI could not be
    # emulated together. DEVICE/PROTOCOL names one device's; --protocol stays the default
    specs = (f"{model}/canopen:0x15", f"{model}:0x30") if default == "other" else \
        (f"{model}:0x15", f"{model}/{protocol}:0x30")
    twins = build_twins(specs, None, None, "firmware", (),
                        protocol if default == "other" else "canopen")
    assert [getattr(twin, "protocol", "canopen") for twin in twins] == ["canopen", protocol]
    with Rig() as rig:
        for twin in twins:
            rig.add(twin)
        monkeypatch.setattr("blinkcan.cli.scan.cli_bus",
                            lambda: SimulatedBus(rig.network, "blinkcan scan"))
        result = CliRunner().invoke(cli, ["scan", "--listen", "0.05"], env={"COLUMNS": "150"})
    assert result.exit_code == 0, result.output
    canopen = [line for line in result.output.splitlines() if "15h" in line]
    other = [line for line in result.output.splitlines() if "30h" in line]
    assert len(canopen) == 1, result.output  # answered its SDO reads at node 15h
    assert protocol.upper() not in canopen[0]
    assert len(other) == 1, result.output  # answered its own protocol's requests at 30h
    assert protocol.upper() in other[0]


@pytest.mark.parametrize("spec", ["keypad/j1939x", "keypad/", "keypad@1.5/can:0x15"])
def test_a_device_protocol_no_device_runs_is_one_line_naming_them(spec: str) -> None:
    result = CliRunner().invoke(cli, ["emulate", "keybox", spec, *NO_BUS])
    assert result.exit_code == 2, result.output
    [line] = result.output.splitlines()
    assert line.startswith("Error: ")
    assert f"not one of {', '.join(device_protocols())}" in line
    assert "no-such-interface" not in result.output


@pytest.mark.parametrize(("model", "protocol"),
                         [(m.name, p) for m in models() for p in device_protocols()
                          if p not in m.description().features and p != "canopen"])
def test_a_device_naming_a_protocol_it_lacks_is_a_usage_error(model: str, protocol: str) -> None:
    result = CliRunner().invoke(cli, ["emulate", f"{model}/{protocol}", *NO_BUS])
    assert result.exit_code == 2, result.output
    assert f"has no {protocol} mode" in result.output
    assert "no-such-interface" not in result.output
