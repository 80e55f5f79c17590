"""Every example frame of the PKP-2600-SI manual rev 1.1, as byte traces against the twin.

Section numbers are the manual's. Where errata.md changes a printed frame, the test says which
row; the state an example implies is set up first through the device's own interface.
"""

from __future__ import annotations

import pytest

from blinkcan.twin import KeypadTwin
from tests.twin.trace import Bench, replayed


@pytest.fixture
def bench() -> Bench:
    """A keypad at factory settings, powered for 10 s (startup show over), pre-operational."""
    bench = Bench(KeypadTwin(node_id=0x15))
    bench.replay("""
        on
        < 715 00
        wait 10
    """)
    return bench


@pytest.fixture
def started(bench: Bench) -> Bench:
    bench.replay("> 000 01 15")
    return bench


def leds(bench: Bench) -> list[tuple[str, str, bool]]:
    keys = bench.twin.snapshot()["keys"]
    return [(k["colour"], k["blink_colour"], k["alternate"]) for k in keys]


def colours(bench: Bench) -> dict[int, str]:
    """Keys whose steady colour is not off."""
    return {i + 1: c for i, (c, _, _) in enumerate(leds(bench)) if c != "off"}


def blinking(bench: Bench) -> dict[int, str]:
    return {i + 1: b for i, (_, b, _) in enumerate(leds(bench)) if b != "off"}


# -- NMT (§4-§8) ---------------------------------------------------------------------------


def test_s4_start(bench: Bench) -> None:
    bench.replay("> 000 01 15\n< -")
    assert bench.twin.snapshot()["nmt_state"] == "operational"


def test_s5_enter_pre_operational(started: Bench) -> None:
    started.replay("> 000 80 15\n< -")
    assert started.twin.snapshot()["nmt_state"] == "pre-operational"


def test_s6_reset_node_sends_boot_up(started: Bench) -> None:
    started.replay("> 000 81 15\n< 715 00")
    assert started.twin.snapshot()["nmt_state"] == "pre-operational"


@pytest.mark.parametrize("command", ["02", "00"])  # §7: 00h is stop for old PKP software
def test_s7_stop(started: Bench, command: str) -> None:
    started.replay(f"> 000 {command} 15\n< -")
    assert started.twin.snapshot()["nmt_state"] == "stopped"


def test_s8_boot_up_at_power_on() -> None:
    Bench(KeypadTwin()).replay("on\n< 715 00")


# -- PDOs (§10-§14) --------------------------------------------------------------------------


#: the manual's examples replayed as they stand, on the started device (``started``): a
#: case each, named by its section and subject
STARTED_EXAMPLES = {
    "s10_key_state_examples": """
        press 4
        < 195 08 00 00 00 ??     # only key #4 pressed
        release 4
        < 195 00 00 00 00 ??     # no key pressed
        press 8
        < 195 80 00 00 00 ??     # only key #8 pressed
        release 8
        < 195 00 00 00 00 ??
        press 6
        < 195 20 00 00 00 ??
        press 1
        < 195 21 00 00 00 ??     # keys #6 and #1 pressed
        release 6
        < 195 01 00 00 00 ??
        release 1
        < 195 00 00 00 00 ??
        press 12
        < 195 00 08 00 00 ??     # only key #12 pressed
    """,
    "s41b_periodic_state_transmission": """
        > 615 2B 00 18 05 00 00 00 00    # switch off
        < 595 60 00 18 05 00 00 00 00
        > 615 2B 00 18 05 32 00 00 00    # 50 ms
        < 595 60 00 18 05 00 00 00 00
        wait 0.05
        < 195 00 00 00 00 ??
        wait 0.05
        < 195 00 00 00 00 ??
        > 615 2B 00 18 05 F4 01 00 00    # 500 ms
        < 595 60 00 18 05 00 00 00 00    # errata P4: printed "60 0 18 05"
        wait 0.25
        < -
        wait 0.25
        < 195 00 00 00 00 ??
    """,
}
test_example_started = replayed(STARTED_EXAMPLES, on="started")


#: the manual's examples replayed as they stand, on the booted device (``bench``): a
#: case each, named by its section and subject
EXAMPLES = {
    "s25_producer_heartbeat": """
        > 615 2B 17 10 00 64 00 00 00
        < 595 60 17 10 00 00 00 00 00
        > 615 40 17 10 00 00 00 00 00    # heartbeat time = 100 ms
        < 595 4B 17 10 00 64 00 00 00
        > 615 2B 17 10 00 00 00 00 00    # switch off
        < 595 60 17 10 00 00 00 00 00
        > 615 2B 17 10 00 32 00 00 00    # 50 ms
        < 595 60 17 10 00 00 00 00 00
        > 615 2B 17 10 00 F4 01 00 00    # 500 ms
        < 595 60 17 10 00 00 00 00 00
    """,
    "s26_device_type": "> 615 40 00 10 00 00 00 00 00\n< 595 43 00 10 00 91 01 0B 00",
    "s27_error_register_not_implemented": ("> 615 40 01 10 00 00 00 00 00\n"
                                           "< 595 80 01 10 00 00 00 02 06"),
    "s28_device_name_segmented": """
        > 615 40 08 10 00 00 00 00 00
        < 595 41 08 10 00 0B 00 00 00
        > 615 60 00 00 00 00 00 00 00
        < 595 00 42 6C 69 6E 6B 4D 61    # BlinkMa
        > 615 70 00 00 00 00 00 00 00
        < 595 17 72 69 6E 65 00 00 00    # rine
    """,
    # errata P5/P6 (Q): the firmware profile sends the strings reversed, as printed
    "s29_s30_versions_as_printed_by_the_firmware": """
        > 615 40 09 10 00 00 00 00 00
        < 595 43 09 10 00 31 30 5F 56
        > 615 40 0A 10 00 00 00 00 00
        < 595 43 0A 10 00 32 2E 32 56
    """,
    "s31_model_id_segmented": """
        > 615 40 0B 10 00 00 00 00 00
        < 595 41 0B 10 00 09 00 00 00
        > 615 60 00 00 00 00 00 00 00
        < 595 00 50 4B 50 32 36 30 30    # PKP2600
        > 615 70 00 00 00 00 00 00 00
        < 595 1B 53 49 00 00 00 00 00    # SI
    """,
    "s32_identity": """
        > 615 40 18 10 00 00 00 00 00
        < 595 4F 18 10 00 04 00 00 00
        > 615 40 18 10 01 00 00 00 00
        < 595 43 18 10 01 E2 03 00 00
    """,
    "s41a_tpdo_parameter": """
        > 615 40 00 18 00 00 00 00 00
        < 595 4F 00 18 00 05 00 00 00
        > 615 40 00 18 01 00 00 00 00
        < 595 43 00 18 01 95 01 00 00
        > 615 40 00 18 02 00 00 00 00
        < 595 4F 00 18 02 FE 00 00 00
        > 615 40 00 18 05 00 00 00 00
        < 595 4B 00 18 05 00 00 00 00    # errata P3: 2 bytes, 4Bh (printed 4Fh)
    """,
    "s42_tpdo_mapping": """
        > 615 40 00 1A 00 00 00 00 00
        < 595 4F 00 1A 00 01 00 00 00
        > 615 40 00 1A 01 00 00 00 00
        < 595 43 00 1A 01 10 01 00 20
    """,
    "s43_serial_number_segmented": """
        > 615 40 00 22 00 00 00 00 00
        < 595 41 00 22 00 08 00 00 00
        > 615 60 00 00 00 00 00 00 00
        < 595 00 46 46 46 46 46 46 46
        > 615 70 00 00 00 00 00 00 00
        < 595 1D 46 00 00 00 00 00 00
    """,
}
test_example = replayed(EXAMPLES)


@pytest.mark.parametrize(("data", "expected"), [
    ("00 00 00 00 00 00 00 00", {}),
    ("01 00 00 00 00 00 00 00", {1: "red"}),
    ("42 00 00 00 00 00 00 00", {2: "red", 7: "red"}),
    ("00 00 01 00 00 00 00 00", {5: "green"}),
    ("00 11 00 00 00 00 00 00", {1: "green", 9: "red"}),
    ("00 00 00 88 00 00 00 00", {4: "blue", 8: "blue"}),
    ("00 CC 00 00 00 00 00 00", {11: "red", 12: "red", 3: "green", 4: "green"}),
])
def test_s11_led_on_examples(started: Bench, data: str, expected: dict[int, str]) -> None:
    started.replay(f"> 215 FF FF FF FF 0F 00 00 00\n> 215 {data}\n< -")
    assert colours(started) == expected


@pytest.mark.parametrize(("data", "expected"), [
    ("00 00 00 00 00 00 00 00", {}),
    ("01 00 00 00 00 00 00 00", {1: "red"}),
    ("09 00 00 00 00 00 00 00", {1: "red", 4: "red"}),
    ("00 00 11 00 00 00 00 00", {5: "green", 9: "green"}),
    ("00 00 00 01 00 00 00 00", {1: "blue"}),
    ("00 00 CC 00 03 00 00 00", {7: "green", 8: "green", 11: "green", 12: "green",
                                 9: "blue", 10: "blue"}),
])
def test_s12_led_blink_examples(started: Bench, data: str, expected: dict[int, str]) -> None:
    started.replay(f"> 315 {data}\n< -")
    assert blinking(started) == expected


def test_s12_alternate_blink_follows_the_bit_table(started: Bench) -> None:
    # errata P9: the printed 315 03 03 is red 9/10 by the bit table; 03 30 is what §12 means
    started.replay("""
        > 215 03 00 00 00 00 00 00 00
        > 315 03 30 00 00 00 00 00 00
    """)
    keys = started.twin.snapshot()["keys"]
    for key in keys[:2]:
        assert key["alternate"] is True
        assert key["phases"] == ["red", "green"]  # "blink red and green in alternate mode"
    started.replay("> 315 03 03 00 00 00 00 00 00")
    assert blinking(started) == {1: "red", 2: "red", 9: "red", 10: "red"}


@pytest.mark.parametrize(("pdo", "entry"), [("415", "indicator_brightness"),
                                            ("515", "backlight_brightness")])
@pytest.mark.parametrize("level", [0x00, 0x08, 0x10, 0x3F])
def test_s13_s14_brightness(started: Bench, pdo: str, entry: str, level: int) -> None:
    started.replay(f"> {pdo} {level:02X} 00 00 00 00 00 00 00\n< -")
    assert started.twin.objects[entry] == level


# -- SDO (§15-§25) ---------------------------------------------------------------------------


@pytest.mark.parametrize(("keys", "reply"), [
    ((), "00 00"), ((1,), "01 00"), ((2,), "02 00"), ((3,), "04 00"), ((4,), "08 00"),
    ((5,), "10 00"), ((6,), "20 00"), ((7,), "40 00"), ((8,), "80 00"), ((1, 2), "03 00"),
    ((10,), "00 02"), (tuple(range(1, 13)), "FF 0F"),
])
def test_s15_read_keys(bench: Bench, keys: tuple[int, ...], reply: str) -> None:
    for key in keys:
        bench.replay(f"press {key}\n< -")  # pre-operational: no PDO, state still read by SDO
    bench.replay(f"> 615 40 00 20 01 00 00 00 00\n< 595 4B 00 20 01 {reply} 00 00")


def test_s16_set_and_read_led_on(bench: Bench) -> None:
    bench.replay("""
        > 615 2B 01 20 01 04 00 00 00    # set red LED #3 on
        < 595 60 01 20 01 00 00 00 00
        > 615 2B 01 20 03 20 00 00 00    # set blue LED #6 on
        < 595 60 01 20 03 00 00 00 00
    """)
    assert colours(bench) == {3: "red", 6: "blue"}
    bench.replay("""
        > 615 2B 01 20 01 08 00 00 00
        < 595 60 01 20 01 00 00 00 00
        > 615 2B 01 20 02 00 01 00 00
        < 595 60 01 20 02 00 00 00 00
        > 615 2B 01 20 03 00 08 00 00
        < 595 60 01 20 03 00 00 00 00
        > 615 40 01 20 01 00 00 00 00    # only red LED #4 on
        < 595 4B 01 20 01 08 00 00 00
        > 615 40 01 20 02 00 00 00 00    # only green LED #9 on
        < 595 4B 01 20 02 00 01 00 00
        > 615 40 01 20 03 00 00 00 00    # only blue LED #12 on
        < 595 4B 01 20 03 00 08 00 00
    """)


def test_s17_set_and_read_led_blink(bench: Bench) -> None:
    bench.replay("""
        > 615 2B 02 20 01 04 00 00 00    # red LED #3 blinks
        < 595 60 02 20 01 00 00 00 00
        > 615 2B 02 20 03 00 02 00 00    # blue LED #10 blinks
        < 595 60 02 20 03 00 00 00 00
    """)
    assert blinking(bench) == {3: "red", 10: "blue"}
    bench.replay("""
        > 615 2B 02 20 01 FF 0F 00 00
        < 595 60 02 20 01 00 00 00 00
        > 615 2B 02 20 02 01 00 00 00
        < 595 60 02 20 02 00 00 00 00
        > 615 2B 02 20 03 00 08 00 00
        < 595 60 02 20 03 00 00 00 00
        > 615 40 02 20 01 00 00 00 00    # all red LEDs blink
        < 595 4B 02 20 01 FF 0F 00 00
        > 615 40 02 20 02 00 00 00 00    # only green LED #1 blinks
        < 595 4B 02 20 02 01 00 00 00
        > 615 40 02 20 03 00 00 00 00    # blue LED #12 blinks
        < 595 4B 02 20 03 00 08 00 00
    """)


@pytest.mark.parametrize(("sub", "value", "entry"), [
    ("01", "20", "indicator_brightness"),          # §18a 50 %
    ("02", "10", "backlight_brightness"),          # §18b 25 %
    ("03", "01", "backlight_colour"),              # §18c red
    ("04", "03", "default_backlight_colour"),      # §18d blue
    ("05", "3F", "startup_indicator_brightness"),  # §18e 100 %
    ("06", "10", "startup_backlight_brightness"),  # §18f 25 %
])
def test_s18_brightness_objects(bench: Bench, sub: str, value: str, entry: str) -> None:
    bench.replay(f"> 615 2F 03 20 {sub} {value} 00 00 00\n< 595 60 03 20 {sub} 00 00 00 00")
    assert bench.twin.objects[entry] == int(value, 16)
    bench.replay(f"> 615 40 03 20 {sub} 00 00 00 00\n< 595 4F 03 20 {sub} {value} 00 00 00")


@pytest.mark.parametrize(("index", "value", "entry"), [
    ("10 20", "03", "baud_rate"),          # §19 250k
    ("11 20", "00", "boot_up_service"),    # §20 not active
    ("12 20", "01", "active_on_startup"),  # §21 active
    ("13 20", "18", "node_id"),            # §22 new node id 18h
    ("14 20", "00", "startup_led_show"),   # §23 disable
    ("00 21", "01", "demo_mode"),          # §24 active
])
def test_s19_to_s24_settings(bench: Bench, index: str, value: str, entry: str) -> None:
    bench.replay(f"> 615 2F {index} 00 {value} 00 00 00\n< 595 60 {index} 00 00 00 00 00")
    assert bench.twin.objects[entry] == int(value, 16)
    assert bench.twin.snapshot()["settings"][entry] == int(value, 16)


def test_s25_heartbeat_message_sequence() -> None:
    bench = Bench(KeypadTwin())
    bench.replay("""
        on
        < 715 00
        > 615 2B 17 10 00 64 00 00 00
        < 595 60 17 10 00 00 00 00 00
        wait 0.1
        < 715 7F                         # pre-operational
        > 000 01 15                      # start keypad 15h
        wait 0.1
        < 715 05                         # operational
    """)


# -- identity and communication objects (§26-§43) ----------------------------------------------


def test_s29_s30_versions_in_cia301_order() -> None:
    bench = Bench(KeypadTwin(quirks="cia301"))
    bench.replay("""
        on
        < 715 00
        > 615 40 09 10 00 00 00 00 00
        < 595 43 09 10 00 56 5F 30 31    # V_01
        > 615 40 0A 10 00 00 00 00 00
        < 595 43 0A 10 00 56 32 2E 32    # V2.2
    """)


@pytest.mark.parametrize(("index", "cob"), [("00", "15 02"), ("01", "15 03"), ("02", "15 04"),
                                            ("03", "15 05")])
def test_s33_to_s36_rpdo_parameters(bench: Bench, index: str, cob: str) -> None:
    bench.replay(f"""
        > 615 40 {index} 14 00 00 00 00 00
        < 595 4F {index} 14 00 02 00 00 00
        > 615 40 {index} 14 01 00 00 00 00
        < 595 43 {index} 14 01 {cob} 00 00
        > 615 40 {index} 14 02 00 00 00 00
        < 595 4F {index} 14 02 FE 00 00 00
    """)


@pytest.mark.parametrize(("index", "entries"), [
    ("00", ["08 01 01 20", "08 02 01 20", "08 03 01 20"]),  # §37
    ("01", ["08 01 02 20", "08 02 02 20", "08 03 02 20"]),  # §38
    ("02", ["08 01 03 20"]),                                # §39
    ("03", ["08 02 03 20"]),                                # §40
])
def test_s37_to_s40_rpdo_mappings(bench: Bench, index: str, entries: list[str]) -> None:
    count = len(entries)
    trace = [f"> 615 40 {index} 16 00 00 00 00 00", f"< 595 4F {index} 16 00 {count:02X} 00 00 00"]
    for sub, entry in enumerate(entries, start=1):
        trace += [f"> 615 40 {index} 16 {sub:02X} 00 00 00 00",
                  f"< 595 43 {index} 16 {sub:02X} {entry}"]
    bench.replay("\n".join(trace))


def test_s44_switch_to_j1939_and_back(bench: Bench) -> None:
    bench.replay("""
        > 615 2B FF 20 01 01             # errata P10: five bytes as printed
        < 595 60 FF 20 01 00 00 00 00
        > 615 40 00 10 00 00 00 00 00    # J1939 mode: CANopen is silent
        < -
        > 000 01 15
        < -
        > 18EF2100 04 1B 80 00 FF FF FF FF
        < 715 00                         # back in CANopen, factory defaults
    """)
    assert bench.twin.snapshot()["protocol"] == "canopen"
