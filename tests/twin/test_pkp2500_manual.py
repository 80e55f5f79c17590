"""Every example frame of the PKP-2500-SI manual rev 1.0's public pages
(pkp-2500-si-canopen.md) against ``KeypadTwin(model="pkp-2500-si")``; § numbers are the
manual's, A-n its errata decisions."""

from __future__ import annotations

import pytest

from blinkcan.twin import KeypadTwin
from tests.twin.trace import Bench, replayed


@pytest.fixture
def bench() -> Bench:
    bench = Bench(KeypadTwin(node_id=0x15, model="pkp-2500-si"))
    bench.replay("on\n< 715 00\nwait 10")  # §8 boot-up; the startup LED show is over by then
    return bench


def words(bench: Bench) -> dict[str, int]:
    return {name: bench.twin.objects.get_int(name) for name in (
        "led_on_red", "led_on_green", "led_on_blue",
        "led_blink_red", "led_blink_green", "led_blink_blue")}


#: the manual's examples replayed as they stand, on the booted device (``bench``): a
#: case each, named by its section and subject
EXAMPLES = {
    "s4_to_s7_nmt": """
        > 000 01 15     # §4 start
        > 000 80 15     # §5 pre-operational
        > 000 01 15
        > 000 02 15     # §7 stop
        > 000 81 15     # §6 reset
        < 715 00        # §8 boot-up
    """,
    "s17_led_on_object": """
        > 615 2B 01 20 01 10 00 00 00   # a) red #5 on
        < 595 60 01 20 01 00 00 00 00
        > 615 2B 01 20 03 00 02 00 00   # a) blue #10 on
        < 595 60 01 20 03 00 00 00 00
        > 615 2B 01 20 01 08 00 00 00
        < 595 60 01 20 01 00 00 00 00
        > 615 2B 01 20 02 80 00 00 00
        < 595 60 01 20 02 00 00 00 00
        > 615 2B 01 20 03 04 00 00 00
        < 595 60 01 20 03 00 00 00 00
        > 615 40 01 20 01 00 00 00 00   # b) only red #4
        < 595 4B 01 20 01 08 00 00 00
        > 615 40 01 20 02 00 00 00 00   # b) only green #8
        < 595 4B 01 20 02 80 00 00 00
        > 615 40 01 20 03 00 00 00 00   # b) only blue #3
        < 595 4B 01 20 03 04 00 00 00
    """,
    "s18_led_blink_object": """
        > 615 2B 02 20 01 02 00 00 00   # a) red #2 blinks
        < 595 60 02 20 01 00 00 00 00
        > 615 2B 02 20 03 00 01 00 00   # a) blue #9 blinks
        < 595 60 02 20 03 00 00 00 00
        > 615 2B 02 20 01 FF 03 00 00
        < 595 60 02 20 01 00 00 00 00
        > 615 2B 02 20 02 10 00 00 00
        < 595 60 02 20 02 00 00 00 00
        > 615 2B 02 20 03 00 00 00 00
        < 595 60 02 20 03 00 00 00 00
        > 615 40 02 20 01 00 00 00 00   # b) all red blink
        < 595 4B 02 20 01 FF 03 00 00
        > 615 40 02 20 02 00 00 00 00   # b) 10h: green #5 (A1: printed "#6")
        < 595 4B 02 20 02 10 00 00 00
        > 615 40 02 20 03 00 00 00 00   # b) no blue blinks
        < 595 4B 02 20 03 00 00 00 00
        > 615 2B 02 20 01 FF FF 00 00   # D-1: bits 10-15 are no LED, read back 0
        < 595 60 02 20 01 00 00 00 00
        > 615 40 02 20 01 00 00 00 00
        < 595 4B 02 20 01 FF 03 00 00
    """,
    "s19_backlight_colours": """
        > 615 2F 03 20 03 06 00 00 00   # c) violet
        < 595 60 03 20 03 00 00 00 00
        > 615 40 03 20 03 00 00 00 00
        < 595 4F 03 20 03 06 00 00 00
        > 615 2F 03 20 04 04 00 00 00   # d) yellow default
        < 595 60 03 20 04 00 00 00 00
        > 615 40 03 20 04 00 00 00 00
        < 595 4F 03 20 04 04 00 00 00
    """,
    "s26_consumer_heartbeat": """
        > 615 40 16 10 00 00 00 00 00
        < 595 4F 16 10 00 01 00 00 00
        > 615 23 16 10 01 64 00 7E 00   # 100 ms from node 7Eh
        < 595 60 16 10 01 00 00 00 00
        > 615 23 16 10 01 F4 01 01 00   # 500 ms from node 01h
        < 595 60 16 10 01 00 00 00 00
        > 615 40 16 10 01 00 00 00 00   # I-27: the cut-off row, as the 2600 rev 1.5
        < 595 43 16 10 01 F4 01 01 00
    """,
    "s38_s39_level_rpdo_parameters": """
        > 615 40 02 14 00 00 00 00 00
        < 595 4F 02 14 00 02 00 00 00
        > 615 40 02 14 01 00 00 00 00
        < 595 43 02 14 01 15 04 00 00
        > 615 40 02 14 02 00 00 00 00
        < 595 4F 02 14 02 FE 00 00 00
        > 615 40 03 14 00 00 00 00 00
        < 595 4F 03 14 00 02 00 00 00
        > 615 40 03 14 01 00 00 00 00
        < 595 43 03 14 01 15 05 00 00
        > 615 40 03 14 02 00 00 00 00
        < 595 4F 03 14 02 FE 00 00 00
    """,
    "s41_blink_mapping_is_three_16_bit_words": """
        > 615 40 01 16 00 00 00 00 00
        < 595 4F 01 16 00 03 00 00 00
        > 615 40 01 16 01 00 00 00 00
        < 595 43 01 16 01 10 01 02 20
        > 615 40 01 16 02 00 00 00 00
        < 595 43 01 16 02 10 02 02 20
        > 615 40 01 16 03 00 00 00 00
        < 595 43 01 16 03 10 03 02 20
    """,
    "s44b_s45_key_state": """
        > 615 2B 00 18 05 00 00 00 00
        < 595 60 00 18 05 00 00 00 00
        > 615 2B 00 18 05 32 00 00 00
        < 595 60 00 18 05 00 00 00 00
        > 615 2B 00 18 05 F4 01 00 00
        < 595 60 00 18 05 00 00 00 00
        > 615 40 00 1A 00 00 00 00 00
        < 595 4F 00 1A 00 01 00 00 00
        > 615 40 00 1A 01 00 00 00 00
        < 595 43 00 1A 01 10 01 00 20   # A2: as printed, the PDO is 5 bytes
        > 615 2B 00 18 05 00 00 00 00
        < 595 60 00 18 05 00 00 00 00
        > 000 01 15
        press 10                        # I-8: key 10 is byte 1 bit 1
        < 195 00 02 00 00 ??
    """,
}
test_example = replayed(EXAMPLES)


def test_s13_blink_pdo_and_alternate_mode(bench: Bench) -> None:
    bench.replay("> 000 01 15")
    for data, blinking in (("00 00 00 00 00 00 00 00", (0, 0, 0)),
                           ("02 00 00 00 00 00 00 00", (1 << 1, 0, 0)),  # red #2
                           ("40 00 00 00 00 00 00 00", (1 << 6, 0, 0)),  # red #7
                           ("00 00 08 00 00 00 00 00", (0, 1 << 3, 0)),  # green #4
                           ("00 00 00 02 00 00 00 00", (0, 1 << 9, 0)),  # green #10
                           ("00 00 00 00 01 01 00 00", (0, 0, 0x101))):  # blue #1 and #9
        bench.replay(f"> 315 {data}")
        got = words(bench)
        assert (got["led_blink_red"], got["led_blink_green"], got["led_blink_blue"]) == blinking
    bench.replay("> 215 FF 03 00 00 00 00 00 00\n> 315 FF 03 FF 03 00 00 00 00")
    keys = bench.twin.snapshot()["commanded"]
    assert all(key["phases"] == ["red", "green"] for key in keys)  # all alternate red/green
    assert len(keys) == 10


def test_s14_s15_levels(bench: Bench) -> None:
    bench.replay("> 000 01 15")
    for cob, data, entry, level in (("415", "1F", "indicator_brightness", 0x1F),
                                    ("415", "3F", "indicator_brightness", 0x3F),
                                    ("515", "00", "backlight_brightness", 0),
                                    ("515", "10", "backlight_brightness", 0x10)):
        bench.replay(f"> {cob} {data} 00 00 00 00 00 00 00")
        assert bench.twin.objects[entry] == level
    assert bench.twin.objects["backlight_colour"] == 0x08  # 515h carries no colour (p. 9)
