"""Every example frame of the PKP-3500-SI manual rev 1.0's public pages
(pkp-3500-si-canopen.md) against ``KeypadTwin(model="pkp-3500-si")``; § numbers are the
manual's, B-n its errata decisions. ``XX`` (the tick timer) is ``??`` here."""

from __future__ import annotations

import pytest

from blinkcan.twin import KeypadTwin
from tests.twin.trace import Bench, replayed


@pytest.fixture
def bench() -> Bench:
    bench = Bench(KeypadTwin(node_id=0x15, model="pkp-3500-si"))
    bench.replay("on\n< 715 00\nwait 10\n> 000 01 15")  # started; the LED show is over
    return bench


#: the manual's examples replayed as they stand, on the booted device (``bench``): a
#: case each, named by its section and subject
EXAMPLES = {
    "s11_key_state": """
        press 1
        < 195 01 00 00 00 ??    # only key 1
        release 1
        < 195 00 00 00 00 ??    # released
        press 5
        < 195 10 00 00 00 ??
        press 1
        < 195 11 00 00 00 ??    # keys 1 and 5
        release 1
        < 195 10 00 00 00 ??
        release 5
        < 195 00 00 00 00 ??
        press 9
        < 195 00 01 00 00 ??
        press 15
        < 195 00 41 00 00 ??    # keys 9 and 15
    """,
    "s19_start_up_levels": """
        > 615 2F 03 20 05 2D 00 00 00   # e) "75 %" (B3: 71 %, stored as sent)
        < 595 60 03 20 05 00 00 00 00
        > 615 40 03 20 05 00 00 00 00
        < 595 4F 03 20 05 2D 00 00 00
        > 615 2F 03 20 06 00 00 00 00   # f) 0 %
        < 595 60 03 20 06 00 00 00 00
        > 615 40 03 20 06 00 00 00 00
        < 595 4F 03 20 06 00 00 00 00
    """,
    "s23_node_id_in_use_at_once": """
        > 615 2F 13 20 00 17 00 00 00
        < 597 60 13 20 00 00 00 00 00   # B4: the acknowledge comes from the new id
        > 617 40 13 20 00 00 00 00 00
        < 597 4F 13 20 00 17 00 00 00
    """,
    "s33_model_id": """
        > 615 40 0B 10 00 00 00 00 00
        < 595 41 0B 10 00 09 00 00 00
        > 615 60 00 00 00 00 00 00 00
        < 595 00 50 4B 50 33 35 30 30   # PKP3500
        > 615 70 00 00 00 00 00 00 00
        < 595 1B 53 49 00 00 00 00 00   # SI
    """,
    "s34_restore_defaults_load": """
        > 615 40 11 10 00 00 00 00 00
        < 595 4F 11 10 00 01 00 00 00
        > 615 23 11 10 01 6C 6F 61 64   # 'load'
        < 595 43 11 10 01 00 00 00 00   # B5: 43h, as printed
    """,
}
test_example = replayed(EXAMPLES)


@pytest.mark.parametrize(("data", "on"), [
    ("00 00 00 00 00 00 00 00", (0, 0, 0)),
    ("01 00 00 00 00 00 00 00", (1, 0, 0)),
    ("00 50 00 00 00 00 00 00", (0x5000, 0, 0)),  # B1: red 13 and 15 (printed "14 and 15")
    ("00 00 0F 00 00 00 00 00", (0, 0x000F, 0)),
    ("00 00 00 70 00 00 00 00", (0, 0x7000, 0)),
    ("00 00 00 00 11 00 00 00", (0, 0, 0x0011)),
    ("01 00 01 00 00 00 00 00", (1, 1, 0)),  # amber 1
    ("00 00 00 40 00 40 00 00", (0, 0x4000, 0x4000)),  # cyan 15
    ("00 02 00 00 00 02 00 00", (0x0200, 0, 0x0200)),  # magenta 10
    ("FF 7F FF 7F FF 7F 00 00", (0x7FFF, 0x7FFF, 0x7FFF)),  # all white
    ("FF FF FF FF FF FF 00 00", (0x7FFF, 0x7FFF, 0x7FFF)),  # D-1: bit 15 is no LED
])
def test_s12_led_on_pdo(bench: Bench, data: str, on: tuple[int, int, int]) -> None:
    bench.replay(f"> 215 {data}")
    assert bench.masks("led_on") == on


@pytest.mark.parametrize(("data", "blink"), [
    ("00 00 00 00 00 00 00 00", (0, 0, 0)),
    ("00 08 00 00 00 00 00 00", (0x0800, 0, 0)),
    ("06 00 00 00 00 00 00 00", (0x0006, 0, 0)),  # B2: red 2 and 3 (printed "2 and 4")
    ("00 00 03 00 00 00 00 00", (0, 0x0003, 0)),
    ("00 00 00 60 00 00 00 00", (0, 0x6000, 0)),
    ("00 00 00 00 09 00 00 00", (0, 0, 0x0009)),
    ("00 00 00 00 00 01 00 00", (0, 0, 0x0100)),
])
def test_s13_led_blink_pdo(bench: Bench, data: str, blink: tuple[int, int, int]) -> None:
    bench.replay(f"> 315 {data}")
    assert bench.masks("led_blink") == blink


def test_s13_alternate_red_and_blue(bench: Bench) -> None:
    bench.replay("> 215 FF 7F 00 00 00 00 00 00\n> 315 FF 7F 00 00 FF 7F 00 00")
    keys = bench.twin.snapshot()["commanded"]
    assert len(keys) == 15
    assert all(key["phases"] == ["red", "blue"] for key in keys)


def test_s14_s15_levels(bench: Bench) -> None:
    for cob, data, entry in (("415", "1F", "indicator_brightness"),
                             ("415", "3F", "indicator_brightness"),
                             ("515", "00", "backlight_brightness"),
                             ("515", "10", "backlight_brightness")):
        bench.replay(f"> {cob} {data} 00 00 00 00 00 00 00")
        assert bench.twin.objects.get_int(entry) == int(data, 16)


@pytest.mark.parametrize(("keys", "reply"), [
    ((), "00 00"), *(((k,), f"{1 << (k - 1) & 0xFF:02X} {1 << (k - 1) >> 8:02X}")
                     for k in range(1, 16)),
    ((1, 2), "03 00"), ((10, 15), "00 42"), (tuple(range(1, 16)), "FF 7F"),
])
def test_s16_keys_state_object(bench: Bench, keys: tuple[int, ...], reply: str) -> None:
    bench.replay("> 000 80 15")  # pre-operational: the presses send no key PDO
    for key in keys:
        bench.replay(f"press {key}")
    bench.replay(f"> 615 40 00 20 01 00 00 00 00\n< 595 4B 00 20 01 {reply} 00 00")


def test_s36_synchronous_led_pdo(bench: Bench) -> None:
    bench.replay("""
        > 615 40 00 14 00 00 00 00 00
        < 595 4F 00 14 00 02 00 00 00
        > 615 40 00 14 01 00 00 00 00
        < 595 43 00 14 01 15 02 00 00
        > 615 40 00 14 02 00 00 00 00
        < 595 4F 00 14 02 FE 00 00 00
        > 615 2F 00 14 02 01 00 00 00
        < 595 60 00 14 02 00 00 00 00
        > 080
        > 215 01 00 00 00 00 00 00 00   # buffered
    """)
    assert bench.masks("led_on") == (0, 0, 0)
    bench.replay("> 080")  # processed at this SYNC
    assert bench.masks("led_on") == (1, 0, 0)
