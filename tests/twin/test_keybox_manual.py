"""Every example frame of the Keybox manual, as byte traces against the twin.

Section numbers are the manual's (KBX). Where errata.md changes a printed frame, the test says
which row; the state an example implies is set up first through the device's own interface.
"""

from __future__ import annotations

import pytest

from blinkcan.devices.model import Quirks
from blinkcan.twin import KeyboxTwin
from tests.twin.trace import Bench, replayed


@pytest.fixture
def bench() -> Bench:
    bench = Bench(KeyboxTwin(node_id=0x0C))
    bench.replay("on\n< 70C 00")
    return bench


@pytest.fixture
def started(bench: Bench) -> Bench:
    bench.replay("> 000 01 0C")
    return bench


def states(bench: Bench) -> dict[int, str]:
    """Pins not OFF."""
    return {p["pin"]: p["state"] for p in bench.twin.snapshot()["pins"] if p["state"] != "off"}


# -- NMT (§11-§16) ----------------------------------------------------------------------------

@pytest.mark.parametrize(("command", "state"), [
    ("01", "operational"), ("80", "pre-operational"), ("02", "stopped"),
])
def test_s11_s12_s14_nmt(bench: Bench, command: str, state: str) -> None:
    bench.replay(f"> 000 {command} 0C\n< -")
    assert bench.twin.snapshot()["nmt_state"] == state


#: the manual's examples replayed as they stand, on the started device (``started``): a
#: case each, named by its section and subject
STARTED_EXAMPLES = {
    "s13_reset_and_s15_boot_up": "> 000 81 0C\n< 70C 00",
    "s18_fault_messages": """
        > 20C 00 00 18 01 00 00 00 00    # pins 4, 5 and 9 HIGH
        blow_fuse 4
        < 18C 08 00 00 00 00 00 00 00
        blow_fuse 5
        < 18C 18 00 00 00 00 00 00 00    # pins 4 and 5 fault state
        > 60C 2F 01 20 04 02 00 00 00    # reset both
        < 58C 60 01 20 04 00 00 00 00
        > 60C 2F 01 20 05 02 00 00 00
        < 58C 60 01 20 05 00 00 00 00
        blow_fuse 9
        < 18C 00 01 00 00 00 00 00 00    # pin 9 fault state
    """,
    "s25_periodic_messages": """
        > 60C 2B 12 20 00 0A 00 00 00
        < 58C 60 12 20 00 00 00 00 00
        > 60C 40 12 20 00 00 00 00 00
        < 58C 4B 12 20 00 0A 00 00 00    # 100 ms (errata K4: 10 ms units)
        wait 0.1
        < 18C 00 00 00 00 00 00 00 00
        > 60C 2B 12 20 00 32 00 00 00    # 500 ms
        < 58C 60 12 20 00 00 00 00 00
        wait 0.4
        < -
        wait 0.1
        < 18C 00 00 00 00 00 00 00 00
    """,
}
test_example_started = replayed(STARTED_EXAMPLES, on="started")


#: the manual's examples replayed as they stand, on the booted device (``bench``): a
#: case each, named by its section and subject
EXAMPLES = {
    "s22_pwm": """
        > 60C 40 09 20 00 00 00 00 00
        < 58C 4F 09 20 00 01 00 00 00
        > 60C 2B 09 20 01 01 01 00 00    # PWM on pin 12, 10 %
        < 58C 60 09 20 01 00 00 00 00
        > 60C 2B 09 20 01 02 05 00 00    # PWM on pin 13, 50 %
        < 58C 60 09 20 01 00 00 00 00
        > 60C 2B 09 20 01 03 08 00 00    # pins 12 and 13, 80 %
        < 58C 60 09 20 01 00 00 00 00
        > 60C 40 09 20 01 00 00 00 00    # who is PWM?
        < 58C 4B 09 20 01 03 08 00 00
    """,
    "s23_baud_rate": """
        > 60C 2F 10 20 00 01 00 00 00
        < 58C 60 10 20 00 00 00 00 00
        > 60C 40 10 20 00 00 00 00 00
        < 58C 4F 10 20 00 01 00 00 00    # 250k
        > 60C 2F 10 20 00 02 00 00 00
        < 58C 60 10 20 00 00 00 00 00
        > 60C 2F 10 20 00 00 00 00 00
        < 58C 60 10 20 00 00 00 00 00
    """,
    "s24_node_id": """
        > 60C 40 11 20 00 00 00 00 00
        < 58C 4F 11 20 00 0C 00 00 00    # errata K6: the stored id (printed 15h)
        > 60C 2F 11 20 00 15 00 00 00
        < 58C 60 11 20 00 00 00 00 00
        > 60C 40 11 20 00 00 00 00 00
        < 58C 4F 11 20 00 15 00 00 00
        > 60C 2F 11 20 00 16 00 00 00
        < 58C 60 11 20 00 00 00 00 00
    """,
    "s28_consumer_heartbeat_time": """
        > 60C 40 16 10 00 00 00 00 00
        < 58C 4F 16 10 00 01 00 00 00
        > 60C 23 16 10 01 64 00 7E 00    # 100 ms from node 7Eh
        < 58C 60 16 10 01 00 00 00 00
        > 60C 23 16 10 01 F4 01 01 00    # 500 ms from node 01h
        < 58C 60 16 10 01 00 00 00 00
        > 60C 40 16 10 01 00 00 00 00
        < 58C 43 16 10 01 F4 01 01 00
    """,
    "s29_producer_heartbeat_time": """
        > 60C 2B 17 10 00 64 00 00 00
        < 58C 60 17 10 00 00 00 00 00
        > 60C 40 17 10 00 00 00 00 00
        < 58C 4B 17 10 00 64 00 00 00
        > 60C 2B 17 10 00 00 00 00 00
        < 58C 60 17 10 00 00 00 00 00
        > 60C 2B 17 10 00 32 00 00 00
        < 58C 60 17 10 00 00 00 00 00
        > 60C 2B 17 10 00 F4 01 00 00
        < 58C 60 17 10 00 00 00 00 00
    """,
    "s30_to_s35_identity": """
        > 60C 40 00 10 00 00 00 00 00
        < 58C 43 00 10 00 91 01 03 00
        > 60C 40 01 10 00 00 00 00 00    # §31 not implemented
        < 58C 80 01 10 00 00 00 02 06
        > 60C 40 08 10 00 00 00 00 00
        < 58C 41 08 10 00 0B 00 00 00
        > 60C 60 00 00 00 00 00 00 00
        < 58C 00 42 6C 69 6E 6B 4D 61
        > 60C 70 00 00 00 00 00 00 00
        < 58C 17 72 69 6E 65 00 00 00
        > 60C 40 09 10 00 00 00 00 00
        < 58C 43 09 10 00 56 5F 30 32    # V_02
        > 60C 40 0A 10 00 00 00 00 00
        < 58C 43 0A 10 00 31 2E 30 30    # 1.00
        > 60C 40 0B 10 00 00 00 00 00
        < 58C 41 0B 10 00 07 00 00 00
        > 60C 60 00 00 00 00 00 00 00
        < 58C 01 4B 65 79 62 6F 78 33    # Keybox3, one last segment
    """,
    "s37_to_s41_communication_objects": """
        > 60C 40 18 10 00 00 00 00 00
        < 58C 4F 18 10 00 01 00 00 00
        > 60C 40 18 10 01 00 00 00 00
        < 58C 43 18 10 01 E2 03 00 00
        > 60C 40 00 14 00 00 00 00 00
        < 58C 4F 00 14 00 02 00 00 00
        > 60C 40 00 14 01 00 00 00 00
        < 58C 43 00 14 01 0C 02 00 00
        > 60C 40 00 14 02 00 00 00 00
        < 58C 4F 00 14 02 FE 00 00 00
        > 60C 40 00 16 00 00 00 00 00
        < 58C 4F 00 16 00 02 00 00 00    # errata K7: 2 mapped objects
        > 60C 40 00 16 01 00 00 00 00
        < 58C 43 00 16 01 10 01 08 20
        > 60C 40 00 16 02 00 00 00 00
        < 58C 43 00 16 02 10 02 08 20
        > 60C 40 00 18 00 00 00 00 00
        < 58C 4F 00 18 00 02 00 00 00
        > 60C 40 00 18 01 00 00 00 00
        < 58C 43 00 18 01 8C 01 00 00
        > 60C 40 00 18 02 00 00 00 00
        < 58C 4F 00 18 02 FE 00 00 00
        > 60C 40 00 1A 00 00 00 00 00
        < 58C 4F 00 1A 00 01 00 00 00
        > 60C 40 00 1A 01 00 00 00 00
        < 58C 43 00 1A 01 10 03 08 20
    """,
}
test_example = replayed(EXAMPLES)


def test_s16_heartbeat_sequence() -> None:
    Bench(KeyboxTwin()).replay("""
        on
        < 70C 00                         # boot up
        > 60C 2B 17 10 00 64 00 00 00
        < 58C 60 17 10 00 00 00 00 00
        wait 0.1
        < 70C 7F                         # pre-operational
        > 000 01 0C
        wait 0.1
        < 70C 05                         # operational
    """)


# -- PDOs (§17, §18) ---------------------------------------------------------------------------

def test_s17_set_output(started: Bench) -> None:
    started.replay("> 20C 00 00 FF 1F 00 00 00 00")  # everything HIGH first
    started.replay("> 20C 81 00 00 00 00 00 00 00\n< -")  # pins 8 and 1 OFF
    assert set(range(1, 14)) - set(states(started)) == {1, 8}
    started.replay("> 20C FF 1F 00 00 00 00 00 00")
    started.replay("> 20C 00 00 00 03 00 00 00 00\n< -")  # pins 9 and 10 HIGH
    assert states(started) == {9: "high", 10: "high"}
    started.replay("> 20C 01 00 02 00 00 00 00 00\n< -")  # pin 1 OFF, pin 2 HIGH
    assert states(started) == {2: "high", 9: "high", 10: "high"}


def test_s17_off_wins_when_both_bits_are_set(started: Bench) -> None:
    started.replay("> 20C 01 00 01 00 00 00 00 00")  # errata K12
    assert states(started) == {}


# -- SDO (§19-§29) ------------------------------------------------------------------------------

def test_s19_single_pin_state(bench: Bench) -> None:
    bench.replay("""
        > 60C 40 01 20 00 00 00 00 00
        < 58C 4F 01 20 00 0D 00 00 00    # errata K1: printed 4F 01 20 0D 00
        > 60C 2F 01 20 04 01 00 00 00
        < 58C 60 01 20 04 00 00 00 00
        > 60C 40 01 20 04 00 00 00 00
        < 58C 4F 01 20 04 01 00 00 00    # pin 4 HIGH
        > 60C 40 01 20 02 00 00 00 00
        < 58C 4F 01 20 02 00 00 00 00    # pin 2 OFF; errata K2: printed 40 01 20 02
        > 60C 2F 01 20 05 02 00 00 00    # RESET pin 5
        < 58C 60 01 20 05 00 00 00 00
        > 60C 2F 01 20 0A 01 00 00 00    # pin 10 HIGH
        < 58C 60 01 20 0A 00 00 00 00
    """)
    assert states(bench) == {4: "high", 10: "high"}


def test_s20_read_digital_input(bench: Bench) -> None:
    bench.replay("set_input 1 1\nset_input 13 1")
    bench.replay("""
        > 60C 40 03 20 00 00 00 00 00
        < 58C 4F 03 20 00 01 00 00 00    # errata K9: printed 4Bh
        > 60C 40 03 20 01 00 00 00 00
        < 58C 4B 03 20 01 01 10 00 00    # pins 1 and 13
    """)


def test_s21_output_state(bench: Bench) -> None:
    # errata K15: "no output OFF" with pins 1-8 HIGH means pins 9-13 are in FAULT
    for pin in range(9, 14):
        bench.replay(f"blow_fuse {pin}")
    bench.replay("""
        > 60C 2B 08 20 02 FF 1F 00 00
        < 58C 60 08 20 02 00 00 00 00
        > 60C 2B 08 20 02 08 00 00 00    # set pin 4 HIGH
        < 58C 60 08 20 02 00 00 00 00
        > 60C 40 08 20 01 00 00 00 00    # who is OFF?
        < 58C 4B 08 20 01 00 00 00 00
        > 60C 40 08 20 02 00 00 00 00    # who is HIGH?
        < 58C 4B 08 20 02 FF 00 00 00
        > 60C 40 08 20 03 00 00 00 00
        < 58C 4B 08 20 03 00 1F 00 00
    """)


@pytest.mark.parametrize("index", ["13", "15"])  # §26 active on startup, §27 boot-up service
def test_s26_s27_flags(bench: Bench, index: str) -> None:
    bench.replay(f"""
        > 60C 2F {index} 20 00 00 00 00 00
        < 58C 60 {index} 20 00 00 00 00 00
        > 60C 40 {index} 20 00 00 00 00 00
        < 58C 4F {index} 20 00 00 00 00 00
        > 60C 2F {index} 20 00 01 00 00 00
        < 58C 60 {index} 20 00 00 00 00 00
    """)


# -- identity and communication objects (§30-§41; errata K10: the first 8 bytes) ------------------

@pytest.mark.parametrize(("quirks", "ack"), [("firmware", "43"), ("cia301", "60")])
def test_s36_restore_default_parameters(quirks: Quirks, ack: str) -> None:
    Bench(KeyboxTwin(quirks=quirks)).replay(f"""
        on
        < 70C 00
        > 60C 40 11 10 00 00 00 00 00
        < 58C 4F 11 10 00 01 00 00 00
        > 60C 23 11 10 01 6C 6F 61 64    # 'load'
        < 58C {ack} 11 10 01 00 00 00 00    # errata K3
    """)
