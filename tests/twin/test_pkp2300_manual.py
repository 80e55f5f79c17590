"""Every example frame of the PKP-2300-SI-FR manual rev 1.3's public pages
(pkp-2300-si-canopen.md, "FR13") against ``KeypadTwin(model="pkp-2300-si")``; § numbers are
the manual's. The older "PKP2300" firmware's frames are not replayed: it is not modelled."""

from __future__ import annotations

import pytest

from blinkcan.twin import KeypadTwin
from tests.twin.trace import Bench, replayed


@pytest.fixture
def bench() -> Bench:
    bench = Bench(KeypadTwin(node_id=0x15, model="pkp-2300-si"))
    bench.replay("on\n< 715 00\nwait 10")  # the startup LED show is over by then
    return bench


#: the manual's examples replayed as they stand, on the booted device (``bench``): a
#: case each, named by its section and subject
EXAMPLES = {
    "s20_s21_boot_up_and_active_on_startup": """
        > 615 2F 11 20 00 00 00 00 00   # boot-up service not active
        < 595 60 11 20 00 00 00 00 00
        > 615 2F 12 20 00 01 00 00 00   # active on start-up
        < 595 60 12 20 00 00 00 00 00
        off
        on                              # no boot-up frame, and operational
        press 6
        < 195 20 00 00 00 ??
    """,
    "s25_producer_heartbeat": """
        > 615 2B 17 10 00 64 00 00 00   # the example's state: 100 ms (E4)
        < 595 60 17 10 00 00 00 00 00
        > 615 40 17 10 00 00 00 00 00
        < 595 4B 17 10 00 64 00 00 00   # heartbeat time = 100 ms
        > 615 2B 17 10 00 00 00 00 00   # off
        < 595 60 17 10 00 00 00 00 00
        > 615 2B 17 10 00 32 00 00 00   # 50 ms
        < 595 60 17 10 00 00 00 00 00
        > 615 2B 17 10 00 F4 01 00 00   # 500 ms
        < 595 60 17 10 00 00 00 00 00
        off
        on
        < 715 00                        # boot up
        wait 0.5
        < 715 7F                        # pre-operational
        > 000 01 15                     # start
        wait 0.5
        < 715 05                        # operational
    """,
    "s26_device_type": """
        > 615 40 00 10 00 00 00 00 00
        < 595 43 00 10 00 91 01 0B 00   # device profile number B0191h
        > 615 40 01 10 00 00 00 00 00   # 1001h: not implemented
        < 595 80 01 10 00 00 00 02 06
    """,
}
test_example = replayed(EXAMPLES)
