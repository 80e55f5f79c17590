"""Every example frame of the PKP-2400-SI manual's public pages (pkp-2400-si-canopen.md,
pp. 17, 18, 32) against ``KeypadTwin(model="pkp-2400-si")``; § numbers are the manual's."""

from __future__ import annotations

import pytest

from blinkcan.twin import KeypadTwin
from tests.twin.trace import Bench, replayed


@pytest.fixture
def bench() -> Bench:
    bench = Bench(KeypadTwin(node_id=0x15, model="pkp-2400-si"))
    bench.replay("on\n< 715 00\nwait 10")  # the startup LED show is over by then
    return bench


#: the manual's examples replayed as they stand, on the booted device (``bench``): a
#: case each, named by its section and subject
EXAMPLES = {
    "s17_default_colour_and_startup_levels": """
        > 615 2F 03 20 04 04 00 00 00   # d) yellow backlight colour
        < 595 60 03 20 04 00 00 00 00
        > 615 2F 03 20 05 2D 00 00 00   # e) "75 %" (erratum E1: 2Dh is 71 %, stored as sent)
        < 595 60 03 20 05 00 00 00 00
        > 615 2F 03 20 06 00 00 00 00   # f) startup backlight level 0 %
        < 595 60 03 20 06 00 00 00 00
        > 615 40 03 20 05 00 00 00 00
        < 595 4F 03 20 05 2D 00 00 00
    """,
    "s18_baud_rate": """
        > 615 2F 10 20 00 02 00 00 00   # 500k
        < 595 60 10 20 00 00 00 00 00
    """,
    "s40b_periodic_state_transmission": """
        > 000 01 15
        > 615 2B 00 18 05 00 00 00 00   # off
        < 595 60 00 18 05 00 00 00 00
        > 615 2B 00 18 05 32 00 00 00   # 50 ms
        < 595 60 00 18 05 00 00 00 00
        wait 0.05
        < 195 00 00 00 00 ??
        > 615 2B 00 18 05 F4 01 00 00   # 500 ms
        < 595 60 00 18 05 00 00 00 00
    """,
    "s41_key_pdo_mapping_is_eight_key_bits": """
        > 615 40 00 1A 00 00 00 00 00
        < 595 4F 00 1A 00 01 00 00 00
        > 615 40 00 1A 01 00 00 00 00
        < 595 43 00 1A 01 08 01 00 20   # 2000h/01, 8 bits
    """,
}
test_example = replayed(EXAMPLES)


def test_keys_in_byte_0_and_leds_one_word_per_colour(bench: Bench) -> None:
    # decision E2 (keys in byte 0) and I-3 (one 16-bit little-endian word per colour)
    bench.replay("""
        > 000 01 15
        press 8
        < 195 80 00 00 00 ??
        > 215 01 00 80 00 00 00 00 00   # red LED 1, green LED 8
        > 615 40 01 20 02 00 00 00 00
        < 595 4B 01 20 02 80 00 00 00
        > 215 00 FF 00 00 00 00 00 00   # bits 9-16 are no LED: they read back 0
        > 615 40 01 20 01 00 00 00 00
        < 595 4B 01 20 01 00 00 00 00
    """)
    assert bench.twin.snapshot()["model"] == "pkp-2400-si"
