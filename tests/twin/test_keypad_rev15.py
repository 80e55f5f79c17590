"""Every example frame of the keypad manual rev 1.5 (firmware V2.8), against
``KeypadTwin(manual="1.5")``. § numbers are rev 1.5's. Where rev 1.5 contradicts itself
(pkp-rev1.1-vs-rev1.5.md section 4) the test says what was decided (errata G1-G6 and here).
Sections whose frames equal rev 1.1's (NMT, 2000h, the PDO bit tables, 1000h, 1008h, 100Bh,
1018h, 2200h, J1939) run through the same rev 1.1 traces below, on the generation 2 twin.
"""

from __future__ import annotations

from collections.abc import Callable

import pytest

from blinkcan.twin import KeypadTwin
from tests.twin import test_keypad_manual as rev11
from tests.twin.trace import Bench


def boot(**kwargs: object) -> Bench:
    bench = Bench(KeypadTwin(manual="1.5", **kwargs))  # type: ignore[arg-type]
    bench.replay("on\n< 715 00\nwait 10")
    return bench


@pytest.fixture
def bench() -> Bench:
    return boot()


@pytest.fixture
def started(bench: Bench) -> Bench:
    bench.replay("> 000 01 15")
    return bench


# -- unchanged sections: the rev 1.1 traces pass on generation 2 ----------------------------------

#: rev 1.1's examples whose frames rev 1.5 keeps (the first two on a started keypad)
UNCHANGED = ["s10_key_state_examples", "s12_alternate_blink_follows_the_bit_table",
             "s26_device_type", "s28_device_name_segmented", "s31_model_id_segmented",
             "s32_identity", "s42_tpdo_mapping", "s43_serial_number_segmented",
             "s44_switch_to_j1939_and_back", "s25_producer_heartbeat",
             "s41a_tpdo_parameter",  # rev 1.5 §44a prints rev 1.1's 1800h reads, 4Bh as P3
             "s27_error_register_not_implemented"]  # rev 1.5 §29: "not yet implemented"


def rev11_example(name: str) -> Callable[[Bench], None]:
    """Rev 1.1's example ``name``: its trace replayed, or its test where it checks more."""
    for table in (rev11.EXAMPLES, rev11.STARTED_EXAMPLES):
        if name in table:
            return lambda bench: bench.replay(table[name])
    test: Callable[[Bench], None] = getattr(rev11, f"test_{name}")
    return test


@pytest.mark.parametrize("name", UNCHANGED)
def test_unchanged_sections(name: str, bench: Bench) -> None:
    if name in UNCHANGED[:2]:
        bench.replay("> 000 01 15")
    rev11_example(name)(bench)


@pytest.mark.parametrize(("keys", "reply"), [((), "00 00"), ((10,), "00 02"),
                                             (tuple(range(1, 13)), "FF 0F")])
def test_s16_keys(bench: Bench, keys: tuple[int, ...], reply: str) -> None:
    rev11.test_s15_read_keys(bench, keys, reply)


# -- §15 backlight setting: byte 1 is the colour (errata G2) --------------------------------------

def test_s15_backlight_pdo_with_colour(started: Bench) -> None:
    started.replay("> 515 20 03 00 00 00 00 00 00\n< -")  # 50 % with blue colour
    assert started.twin.snapshot()["backlight"] == {"colour": "blue", "level": 0x20}
    started.replay("> 515 00 00 00 00 00 00 00 00")  # turn off the backlight
    assert started.twin.snapshot()["backlight"] == {"colour": "amber", "level": 0}


def test_s15_colour_00_or_out_of_range_is_the_default_colour(started: Bench) -> None:
    started.replay("""
        > 615 2F 03 20 04 02 00 00 00    # default colour green
        < 595 60 03 20 04 00 00 00 00
        > 515 10 05                      # cyan
        > 515 10 00                      # 00h: the default colour
        > 615 40 03 20 03 00 00 00 00    # 2003h/03 reads the colour in use
        < 595 4F 03 20 03 02 00 00 00
        > 515 10 0A                      # out of range: the default colour too
        > 515 18                         # DLC 1: only the level
        > 515 40 03                      # level > 3Fh: the whole frame is ignored
    """)
    assert started.twin.snapshot()["backlight"] == {"colour": "green", "level": 0x18}


# -- §17/§18: 2001h/2002h follow the PDO bytes ----------------------------------------------------

def test_s17_led_on_new_layout(bench: Bench) -> None:
    bench.replay("""
        > 615 2B 01 20 01 04 00 00 00    # red LED #3
        < 595 60 01 20 01 00 00 00 00
        > 615 2B 01 20 01 00 80 00 00    # green LED #4 (sub 1 carries green 1-4)
        < 595 60 01 20 01 00 00 00 00
    """)
    assert rev11.colours(bench) == {4: "green"}  # the second write replaced red #3
    bench.replay("""
        > 615 2F 01 20 02 01 00 00 00    # printed "green LED #1": in sub 2, 01h is green #5
        < 595 60 01 20 02 00 00 00 00
        > 615 2F 01 20 02 40 00 00 00    # green LED #11
        < 595 60 01 20 02 00 00 00 00
        > 615 2B 01 20 03 02 00 00 00    # blue LED #2
        < 595 60 01 20 03 00 00 00 00
        > 615 2B 01 20 03 00 08 00 00    # blue LED #12
        < 595 60 01 20 03 00 00 00 00
    """)
    assert rev11.colours(bench) == {4: "green", 11: "green", 12: "blue"}
    bench.replay("""
        > 615 2B 01 20 01 08 00 00 00
        < 595 60 01 20 01 00 00 00 00
        > 615 2F 01 20 02 10 00 00 00
        < 595 60 01 20 02 00 00 00 00
        > 615 40 01 20 01 00 00 00 00    # only red LED #4 on
        < 595 4B 01 20 01 08 00 00 00
        > 615 40 01 20 02 00 00 00 00    # only green LED #9 on
        < 595 4F 01 20 02 10 00 00 00
        > 615 40 01 20 03 00 00 00 00    # only blue LED #12 on
        < 595 4B 01 20 03 00 08 00 00
        > 615 2B 01 20 02 01 00 00 00    # sub 2 is 8 bits: a 2-byte write has the wrong length
        < 595 80 01 20 02 10 00 07 06
    """)


def test_s18_led_blink_new_layout(bench: Bench) -> None:
    bench.replay("""
        > 615 2B 02 20 01 08 00 00 00    # red LED #4 blinks
        < 595 60 02 20 01 00 00 00 00
        > 615 2B 02 20 01 00 10 00 00    # green LED #1 blinks
        < 595 60 02 20 01 00 00 00 00
        > 615 2F 02 20 02 02 00 00 00    # green LED #6 blinks
        < 595 60 02 20 02 00 00 00 00
        > 615 2F 02 20 02 20 00 00 00    # green LED #10 blinks
        < 595 60 02 20 02 00 00 00 00
    """)
    assert rev11.blinking(bench) == {1: "green", 10: "green"}
    bench.replay("""
        > 615 2B 01 20 03 80 00 00 00    # printed with 2001h: as printed, blue #8 turns ON
        < 595 60 01 20 03 00 00 00 00
        > 615 2B 01 20 03 00 01 00 00    # ... then blue #9 ON
        < 595 60 01 20 03 00 00 00 00
    """)
    assert rev11.colours(bench) == {9: "blue"}
    bench.replay("""
        > 615 2B 02 20 01 FF 00 00 00
        < 595 60 02 20 01 00 00 00 00
        > 615 2F 02 20 02 0F 00 00 00
        < 595 60 02 20 02 00 00 00 00
        > 615 2B 02 20 03 FF 0F 00 00
        < 595 60 02 20 03 00 00 00 00
        > 615 40 02 20 01 00 00 00 00    # red LED #1-8 blink
        < 595 4B 02 20 01 FF 00 00 00
        > 615 40 02 20 02 00 00 00 00    # green LED #5-8 blink
        < 595 4F 02 20 02 0F 00 00 00
        > 615 40 02 20 03 00 00 00 00    # blue LED #1-12 blink
        < 595 4B 02 20 03 FF 0F 00 00
    """)


def test_setting_red_by_sdo_carries_green_1_to_4(started: Bench) -> None:
    # the trap of issue 7: on generation 2, sub 1 holds green 1-4 too
    started.replay("> 215 00 F0 00 00 00 00 00 00")  # green 1-4 on by PDO
    started.replay("""
        > 615 40 01 20 01 00 00 00 00
        < 595 4B 01 20 01 00 F0 00 00
        > 615 2B 01 20 01 01 F0 00 00    # red #1 on, green 1-4 carried along
        < 595 60 01 20 01 00 00 00 00
    """)
    assert rev11.colours(started) == {1: "yellow", 2: "green", 3: "green", 4: "green"}


# -- §19-§24: settings read back with 4Fh ---------------------------------------------------------

@pytest.mark.parametrize(("index_sub", "value"), [
    ("03 20 01", "09"), ("03 20 02", "0D"),
    ("03 20 03", "05"),  # printed read-back 04h "Cyan" after writing 05h: reads what was written
    ("03 20 04", "06"), ("03 20 05", "13"),
    ("03 20 06", "16"),  # errata G6: the level belongs in byte 4
    ("10 20 00", "04"), ("11 20 00", "01"),
    ("12 20 00", "01"),  # printed read-back 00h after writing 01h: reads what was written
    ("14 20 00", "02"),
])
def test_s19_to_s24_write_then_read(bench: Bench, index_sub: str, value: str) -> None:
    bench.replay(f"""
        > 615 2F {index_sub} {value} 00 00 00
        < 595 60 {index_sub} 00 00 00 00
        > 615 40 {index_sub} 00 00 00 00
        < 595 4F {index_sub} {value} 00 00 00
    """)


def test_s23_node_id_applies_at_once_and_acknowledges_from_it(bench: Bench) -> None:
    bench.replay("""
        > 615 2F 13 20 00 3A 00 00 00
        < 5BA 60 13 20 00 00 00 00 00    # errata G1: from the new id
        > 63A 40 13 20 00 00 00 00 00
        < 5BA 4F 13 20 00 3A 00 00 00
        > 615 40 00 10 00 00 00 00 00    # the old id is gone
        < -
    """)


def test_s25_demo_mode(bench: Bench) -> None:
    bench.replay("> 615 2F 00 21 00 01 00 00 00\n< 595 60 00 21 00 00 00 00 00")


# -- §26 1016h consumer heartbeat (errata G4) -----------------------------------------------------

def test_s26_consumer_heartbeat_time(bench: Bench) -> None:
    bench.replay("""
        > 615 40 16 10 00 00 00 00 00
        < 595 4F 16 10 00 01 00 00 00
        > 615 23 16 10 01 64 00 7E 00
        < 595 60 16 10 01 00 00 00 00
        > 615 23 16 10 01 F4 01 01 00
        < 595 60 16 10 01 00 00 00 00
        > 615 40 16 10 01 00 00 00 00
        < 595 43 16 10 01 F4 01 01 00
    """)


@pytest.mark.parametrize("value", [
    "05 00 01 00",  # 5 ms
    "64 00 00 00",  # node 00h
    "64 00 15 00",  # the keypad's own id
    "64 00 80 00",  # node 80h
])
def test_s26_invalid_consumer_entries_abort(bench: Bench, value: str) -> None:
    bench.replay(f"> 615 23 16 10 01 {value}\n< 595 80 16 10 01 30 00 09 06")


def test_s26_consumer_time_up_to_65535_ms(bench: Bench) -> None:
    bench.replay("> 615 23 16 10 01 FF FF 01 00\n< 595 60 16 10 01 00 00 00 00")


def test_s26_heartbeat_loss_switches_leds_off_until_an_nmt_start(started: Bench) -> None:
    started.replay("""
        > 615 23 16 10 01 64 00 01 00
        < 595 60 16 10 01 00 00 00 00
        > 215 FF 0F 00 00 00 00 00 00
        > 515 30 01
        > 701 05
        wait 0.15
    """)
    snapshot = started.twin.snapshot()
    assert snapshot["nmt_state"] == "pre-operational"
    assert snapshot["heartbeat_consumer"]["state"] == "lost"
    assert rev11.colours(started) == {}
    assert snapshot["backlight"]["level"] == 0
    started.replay("> 701 05\n> 000 01 15")
    assert started.twin.snapshot()["nmt_state"] == "operational"


# -- §31/§32 versions in order; §34 restore defaults ----------------------------------------------

@pytest.mark.parametrize("quirks", ["firmware", "cia301"])
def test_s31_s32_versions_in_order(quirks: str) -> None:
    boot(quirks=quirks).replay("""
        > 615 40 09 10 00 00 00 00 00
        < 595 43 09 10 00 56 5F 30 31    # V_01
        > 615 40 0A 10 00 00 00 00 00
        < 595 43 0A 10 00 56 32 2E 38    # V2.8
    """)


@pytest.mark.parametrize(("quirks", "ack"), [("firmware", "43"), ("cia301", "60")])
def test_s34_restore_defaults(quirks: str, ack: str) -> None:
    bench = boot(quirks=quirks)
    bench.replay(f"""
        > 615 2B 17 10 00 64 00 00 00
        < 595 60 17 10 00 00 00 00 00
        > 615 2F 10 20 00 03 00 00 00
        < 595 60 10 20 00 00 00 00 00
        > 615 40 11 10 00 00 00 00 00
        < 595 4F 11 10 00 01 00 00 00
        > 615 23 11 10 01 6C 6F 61 64    # 'load'
        < 595 {ack} 11 10 01 00 00 00 00    # errata G5
        > 615 23 11 10 01 73 61 76 65    # a wrong signature
        < 595 80 11 10 01 20 00 00 08
        wait 0.1
        < 715 7F                         # the running heartbeat goes on until the reset
        > 000 81 15
        < 715 00
        wait 1
        < -
    """)
    assert bench.twin.snapshot()["bitrate"] == 125_000


# -- §36-§44: PDO parameters, SYNC ----------------------------------------------------------------

def test_s36_synchronous_led_on(started: Bench) -> None:
    started.replay("""
        > 615 40 00 14 02 00 00 00 00
        < 595 4F 00 14 02 FE 00 00 00
        > 615 2F 00 14 02 01 00 00 00    # synchronous RPDO 0
        < 595 60 00 14 02 00 00 00 00
        > 080
        > 215 01 00 00 00 00 00 00 00    # held
    """)
    assert rev11.colours(started) == {}
    started.replay("> 215 02 00 00 00 00 00 00 00\n> 080")  # the last one before the SYNC wins
    assert rev11.colours(started) == {2: "red"}


def test_s37_synchronous_led_blink(started: Bench) -> None:
    started.replay("""
        > 615 2F 01 14 02 00 00 00 00    # type 00h: synchronous too
        < 595 60 01 14 02 00 00 00 00
        > 080
        > 315 00 10 00 00 00 00 00 00    # green LED 1 blinking, held
    """)
    assert rev11.blinking(started) == {}
    started.replay("> 080")
    assert rev11.blinking(started) == {1: "green"}


@pytest.mark.parametrize(("index", "value"), [("00 14", "F1"), ("01 14", "FF"), ("00 18", "00"),
                                              ("00 18", "F5")])
def test_undocumented_transmission_types_abort(bench: Bench, index: str, value: str) -> None:
    bench.replay(f"> 615 2F {index} 02 {value} 00 00 00\n< 595 80 {index} 02 30 00 09 06")


@pytest.mark.parametrize(("index", "cob"), [("00 14", "15 02"), ("01 14", "15 03")])
def test_s36_s37_rpdo_parameters(bench: Bench, index: str, cob: str) -> None:
    """§36/§37's reads of 1400h/1401h, before their SYNC examples (test_s36/test_s37)."""
    rev11.test_s33_to_s36_rpdo_parameters(bench, index.split(maxsplit=1)[0], cob)


@pytest.mark.parametrize(("index", "cob"), [("02 14", "15 04"), ("03 14", "15 05")])
def test_s38_s39_rpdo_parameters(bench: Bench, index: str, cob: str) -> None:
    rev11.test_s33_to_s36_rpdo_parameters(bench, index.split(maxsplit=1)[0], cob)


@pytest.mark.parametrize(("index", "entries"), [
    ("00", ["10 01 01 20", "08 02 01 20", "10 03 01 20"]),  # §40
    ("01", ["10 01 02 20", "08 02 02 20", "10 03 02 20"]),  # §41
    ("02", ["08 01 03 20"]),                                # §42
    ("03", ["08 02 03 20", "08 03 03 20"]),                 # §43: sub 02h = 2003h/03
])
def test_s40_to_s43_mappings(bench: Bench, index: str, entries: list[str]) -> None:
    rev11.test_s37_to_s40_rpdo_mappings(bench, index, entries)


def test_s44a_synchronous_key_state(started: Bench) -> None:
    started.replay("""
        > 615 40 00 18 05 00 00 00 00
        < 595 4B 00 18 05 00 00 00 00
        > 615 2F 00 18 02 01 00 00 00    # cyclic every SYNC
        < 595 60 00 18 02 00 00 00 00
        > 080
        < 195 00 00 00 00 ??             # sampled at this SYNC
        press 1
        < -                              # no message on the CAN bus
        > 080
        < 195 01 00 00 00 ??
        > 615 2F 00 18 02 02 00 00 00    # every 2nd SYNC from the next one
        < 595 60 00 18 02 00 00 00 00
        > 080
        < -
        > 080
        < 195 01 00 00 00 ??
        > 615 2F 00 18 02 FE 00 00 00    # event-driven again
        < 595 60 00 18 02 00 00 00 00
        release 1
        < 195 00 00 00 00 ??
    """)


def test_s44b_periodic_state_transmission(started: Bench) -> None:
    started.replay(rev11.STARTED_EXAMPLES["s41b_periodic_state_transmission"])


@pytest.mark.parametrize(("data", "expected"), [  # rev 1.5 §12
    ("00 00 00 00 00 00 00 00", {}), ("01 00 00 00 00 00 00 00", {1: "red"}),
    ("42 00 00 00 00 00 00 00", {2: "red", 7: "red"}),
    ("00 00 01 00 00 00 00 00", {5: "green"}),
])
def test_s12_led_on(started: Bench, data: str, expected: dict[int, str]) -> None:
    rev11.test_s11_led_on_examples(started, data, expected)


@pytest.mark.parametrize(("data", "expected"), [  # rev 1.5 §13
    ("00 00 00 00 00 00 00 00", {}), ("01 00 00 00 00 00 00 00", {1: "red"}),
    ("09 00 00 00 00 00 00 00", {1: "red", 4: "red"}),
    ("00 00 11 00 00 00 00 00", {5: "green", 9: "green"}),
    ("00 00 00 01 00 00 00 00", {1: "blue"}),
    ("00 00 CC 00 03 00 00 00", {7: "green", 8: "green", 11: "green", 12: "green",
                                 9: "blue", 10: "blue"}),
])
def test_s13_led_blink(started: Bench, data: str, expected: dict[int, str]) -> None:
    rev11.test_s12_led_blink_examples(started, data, expected)


@pytest.mark.parametrize("level", [0x08, 0x10])  # rev 1.5 §14
def test_s14_indicator_brightness(started: Bench, level: int) -> None:
    rev11.test_s13_s14_brightness(started, "415", "indicator_brightness", level)


@pytest.mark.parametrize("command", ["01 15", "80 15", "02 15"])  # rev 1.5 §4, §5, §7
def test_s4_to_s7_nmt(bench: Bench, command: str) -> None:
    bench.replay(f"> 000 {command}\n< -")


def test_s6_s8_reset_and_boot_up(bench: Bench) -> None:
    bench.replay("> 000 81 15\n< 715 00")


def test_s23_the_new_node_id_is_stored_too() -> None:
    bench = boot()
    bench.replay("> 615 2F 13 20 00 3A 00 00 00\n< 5BA 60 13 20 00 00 00 00 00\noff\non\n< 73A 00")
