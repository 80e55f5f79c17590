"""Every example frame of the PKP-2200-SI manual rev 1.0's public pages
(pkp-2200-si-canopen.md) against ``KeypadTwin(model="pkp-2200-si")``; § numbers are the
manual's. ``XX`` (the tick timer) is ``??`` here."""

from __future__ import annotations

import pytest

from blinkcan.twin import KeypadTwin
from tests.twin.trace import Bench, replayed


@pytest.fixture
def bench() -> Bench:
    bench = Bench(KeypadTwin(node_id=0x15, model="pkp-2200-si"))
    bench.replay("on\n< 715 00\nwait 10")  # §8 boot-up; the startup LED show is over by then
    return bench


def test_s7_stop_and_s8_boot_up(bench: Bench) -> None:
    bench.replay("> 000 01 15\n> 000 02 15\n> 000 81 15\n< 715 00")
    assert bench.twin.nmt_state.name == "PRE_OPERATIONAL"


#: the manual's examples replayed as they stand, on the booted device (``bench``): a
#: case each, named by its section and subject
EXAMPLES = {
    "s11_key_state": """
        > 000 01 15
        press 1
        < 195 01 00 00 00 ??    # key 1
        release 1
        < 195 00 00 00 00 ??    # no key
        press 4
        < 195 08 00 00 00 ??    # key 4
        release 4
        < 195 00 00 00 00 ??
        press 1
        < 195 01 00 00 00 ??
        press 3
        < 195 05 00 00 00 ??    # keys 1 and 3
        press 2
        < 195 07 00 00 00 ??
        press 4
        < 195 0F 00 00 00 ??    # all keys
    """,
    "s43a_key_pdo_parameters": """
        > 615 40 00 18 00 00 00 00 00
        < 595 4F 00 18 00 05 00 00 00
        > 615 40 00 18 01 00 00 00 00
        < 595 43 00 18 01 95 01 00 00
        > 615 40 00 18 02 00 00 00 00
        < 595 4F 00 18 02 FE 00 00 00
        > 615 40 00 18 05 00 00 00 00
        < 595 4B 00 18 05 00 00 00 00   # periodic transmission disabled
        > 615 2F 00 18 02 01 00 00 00   # (the row is cut on p. 31) every SYNC
        < 595 60 00 18 02 00 00 00 00
        > 000 01 15
        press 2
        > 080
        < 195 02 00 00 00 ??
    """,
}
test_example = replayed(EXAMPLES)


@pytest.mark.parametrize(("data", "on"), [
    ("00 00 00 00 00 00 00 00", (0, 0, 0)),
    ("01 00 00 00 00 00 00 00", (1, 0, 0)),
    ("00 0A 00 00 00 00 00 00", (0, 0x0A, 0)),  # green 2 and 4
    ("00 00 08 00 00 00 00 00", (0, 0, 0x08)),
    ("00 00 01 00 00 00 00 00", (0, 0, 0x01)),
    ("09 00 00 00 00 00 00 00", (0x09, 0, 0)),  # red 1 and 4
    ("FF FF FF 00 00 00 00 00", (0x0F, 0x0F, 0x0F)),  # bits 4-7 are no LED
])
def test_s12_led_on_pdo(bench: Bench, data: str, on: tuple[int, int, int]) -> None:
    bench.replay(f"> 000 01 15\n> 215 {data}")
    assert bench.masks("led_on") == on


@pytest.mark.parametrize(("index", "cob", "sync_type", "prefix", "data", "lit"), [
    ("00", "15 02", "01", "led_on", "215 01 00 00", (1, 0, 0)),  # §35: red LED 1
    # §36 sets type 00h ("00h-F0h synchronous", p. 26), not §35's 01h: as printed
    ("01", "15 03", "00", "led_blink", "315 00 01 00", (0, 1, 0)),  # green LED 1 blinks
])
def test_s35_s36_synchronous_led_pdos(bench: Bench, index: str, cob: str, sync_type: str,
                                      prefix: str, data: str, lit: tuple[int, int, int]) -> None:
    bench.replay(f"""
        > 000 01 15
        > 615 40 {index} 14 00 00 00 00 00
        < 595 4F {index} 14 00 02 00 00 00
        > 615 40 {index} 14 01 00 00 00 00
        < 595 43 {index} 14 01 {cob} 00 00
        > 615 40 {index} 14 02 00 00 00 00
        < 595 4F {index} 14 02 FE 00 00 00
        > 615 2F {index} 14 02 {sync_type} 00 00 00
        < 595 60 {index} 14 02 00 00 00 00
        > 080
        > {data} 00 00 00 00 00         # buffered
    """)
    assert bench.masks(prefix) == (0, 0, 0)
    bench.replay("> 080")  # processed at this SYNC
    assert bench.masks(prefix) == lit
