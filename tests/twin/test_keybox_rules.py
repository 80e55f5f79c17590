"""Keybox rules in words (KBX §5-§9, §17-§28) and errata.md decisions, beyond the examples."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from blinkcan.twin import KeyboxTwin
from tests.twin.trace import Bench


def boot(**kwargs: object) -> Bench:
    bench = Bench(KeyboxTwin(**kwargs))  # type: ignore[arg-type]
    bench.replay("on\n< 70C 00")
    return bench


@pytest.fixture
def started() -> Bench:
    bench = boot()
    bench.replay("> 000 01 0C")
    return bench


def pin(bench: Bench, number: int) -> dict[str, object]:
    pins: list[dict[str, object]] = bench.twin.snapshot()["pins"]
    return pins[number - 1]


# -- outputs and faults (KBX §7, §17-§21) ---------------------------------------------------------

def test_blowing_the_fuse_of_an_off_pin_faults_when_commanded_high(started: Bench) -> None:
    started.replay("""
        blow_fuse 3
        < -
        > 20C 00 00 04 00 00 00 00 00
        < 18C 04 00 00 00 00 00 00 00
    """)
    assert pin(started, 3)["state"] == "fault"


def test_fault_is_latched_until_reset_even_with_a_new_fuse(started: Bench) -> None:
    started.replay("""
        > 20C 00 00 01 00 00 00 00 00
        blow_fuse 1
        < 18C 01 00 00 00 00 00 00 00
        replace_fuse 1
        < -
        > 20C 01 00 00 00 00 00 00 00    # OFF does not clear FAULT (errata K12)
        > 60C 40 01 20 01 00 00 00 00
        < 58C 4F 01 20 01 03 00 00 00
        > 60C 2F 01 20 01 02 00 00 00    # RESET
        < 58C 60 01 20 01 00 00 00 00
        > 60C 40 01 20 01 00 00 00 00
        < 58C 4F 01 20 01 00 00 00 00    # back to OFF
    """)


def test_no_fault_pdo_outside_operational_but_the_fault_is_read() -> None:
    bench = boot()
    bench.replay("""
        > 60C 2F 01 20 06 01 00 00 00
        < 58C 60 01 20 06 00 00 00 00
        blow_fuse 6
        < -
        > 60C 40 08 20 03 00 00 00 00
        < 58C 4B 08 20 03 20 00 00 00
    """)


def test_commanding_high_with_a_blown_fuse_by_sdo_reports_after_the_ack(started: Bench) -> None:
    started.replay("""
        blow_fuse 7
        > 60C 2F 01 20 07 01 00 00 00
        < 58C 60 01 20 07 00 00 00 00
        < 18C 40 00 00 00 00 00 00 00
    """)


def test_low_side_pins_detect_no_fault_and_read_low_when_driven() -> None:
    bench = boot(low_side=(2,))
    bench.replay("""
        > 000 01 0C
        blow_fuse 2
        set_input 2 1
        > 20C 00 00 06 00 00 00 00 00    # pins 2 (low side) and 3 HIGH
        > 60C 40 03 20 01 00 00 00 00
        < 58C 4B 03 20 01 04 00 00 00    # pin 3 reads high, pin 2 pulled to ground
    """)
    assert pin(bench, 2)["state"] == "high"
    assert pin(bench, 2)["low_side"] is True


def test_only_pins_2_and_5_can_be_low_side() -> None:
    with pytest.raises(ValueError, match="only pins"):
        KeyboxTwin(low_side=(3,))


def test_inputs_read_the_driven_level_or_the_external_one(started: Bench) -> None:
    started.replay("""
        > 20C 00 00 01 00 00 00 00 00
        set_input 5 1
        blow_fuse 1                      # a faulted pin floats: its input reads external
        < 18C 01 00 00 00 00 00 00 00
        > 60C 40 03 20 01 00 00 00 00
        < 58C 4B 03 20 01 10 00 00 00
    """)


@pytest.mark.parametrize(("request_", "reply"), [
    ("2F 01 20 01 03 00 00 00", "80 01 20 01 30 00 09 06"),  # FAULT is read-only (§19)
    ("2F 01 20 0E 01 00 00 00", "80 01 20 0E 11 00 09 06"),  # pin 14
    ("2B 08 20 03 01 00 00 00", "80 08 20 03 02 00 01 06"),  # 2008h/03 read-only
    ("40 08 20 06 00 00 00 00", "80 08 20 06 11 00 09 06"),  # errata K5
    ("2B 08 20 02 00 20 00 00", "80 08 20 02 30 00 09 06"),  # bit 14
    ("2B 09 20 01 04 05 00 00", "80 09 20 01 30 00 09 06"),  # PWM bit 2 (K16)
    ("2B 09 20 01 01 0B 00 00", "80 09 20 01 30 00 09 06"),  # duty > 0Ah
    ("2F 10 20 00 03 00 00 00", "80 10 20 00 30 00 09 06"),  # baud code 3 (B1)
    ("2F 11 20 00 80 00 00 00", "80 11 20 00 30 00 09 06"),  # node id 80h
    ("23 16 10 01 05 00 01 00", "80 16 10 01 30 00 09 06"),  # consumer 5 ms (K8)
    ("23 16 10 01 64 00 00 00", "80 16 10 01 30 00 09 06"),  # consumer node 0
    ("23 16 10 01 64 00 01 01", "80 16 10 01 30 00 09 06"),  # reserved byte set
    ("23 11 10 01 73 61 76 65", "80 11 10 01 20 00 00 08"),  # wrong signature ("save")
    ("2B 17 10 00 00 FF 00 00", "80 17 10 00 30 00 09 06"),  # 1017h 65280 ms (K17)
])
def test_keybox_abort_codes(request_: str, reply: str) -> None:
    boot().replay(f"> 60C {request_}\n< 58C {reply}")


def test_output_mask_writes_change_only_the_pins_whose_bit_is_set(started: Bench) -> None:
    """Errata K20: a 2008h/01 write switches OFF exactly the pins whose bit is 1 and a 2008h/02
    write drives HIGH exactly those; every other pin keeps its state (as the RPDO)."""
    started.replay("""
        > 60C 2B 08 20 02 07 00 00 00    # pins 1, 2, 3 HIGH
        < 58C 60 08 20 02 00 00 00 00
        > 60C 2B 08 20 01 02 00 00 00    # pin 2 OFF
        < 58C 60 08 20 01 00 00 00 00
        > 60C 40 08 20 02 00 00 00 00
        < 58C 4B 08 20 02 05 00 00 00    # pins 1 and 3 still HIGH
        > 60C 2B 08 20 02 08 00 00 00    # pin 4 HIGH
        < 58C 60 08 20 02 00 00 00 00
        > 60C 40 08 20 02 00 00 00 00
        < 58C 4B 08 20 02 0D 00 00 00    # pins 1, 3, 4
        > 60C 40 08 20 01 00 00 00 00
        < 58C 4B 08 20 01 F2 1F 00 00    # the other nine OFF
    """)


def test_sdo_output_writes_act_in_pre_operational_rpdo_does_not() -> None:
    bench = boot()
    bench.replay("> 20C 00 00 01 00 00 00 00 00")
    assert pin(bench, 1)["state"] == "off"  # errata K19: RPDO only in operational
    bench.replay("> 60C 2B 08 20 02 01 00 00 00\n< 58C 60 08 20 02 00 00 00 00")
    assert pin(bench, 1)["state"] == "high"


def test_masks_always_partition_the_pins(started: Bench) -> None:
    started.replay("> 20C 00 00 FF 1F 00 00 00 00\nblow_fuse 2\n< 18C 02 00 00 00 00 00 00 00")
    objects = started.twin.objects
    off, high, fault = (objects.get_int(n) for n in
                        ("output_off_mask", "output_high_mask", "output_fault_mask"))
    assert off | high | fault == 0x1FFF
    assert off & high == off & fault == high & fault == 0


# -- PWM (KBX §22, errata K16) --------------------------------------------------------------------

def test_pwm_pins_read_high_off_at_duty_0_and_leaving_pwm_goes_off(started: Bench) -> None:
    started.replay("> 60C 2B 09 20 01 03 05 00 00\n< 58C 60 09 20 01 00 00 00 00")
    assert (pin(started, 12)["state"], pin(started, 12)["pwm_percent"]) == ("high", 50)
    started.replay("> 60C 2B 09 20 01 03 00 00 00\n< 58C 60 09 20 01 00 00 00 00")
    assert pin(started, 13)["state"] == "off"
    started.replay("> 60C 2B 09 20 01 01 0A 00 00\n< 58C 60 09 20 01 00 00 00 00")
    assert (pin(started, 12)["state"], pin(started, 13)["state"]) == ("high", "off")
    assert pin(started, 13)["pwm_percent"] is None
    started.replay("> 60C 2B 09 20 01 00 00 00 00\n< 58C 60 09 20 01 00 00 00 00")
    assert pin(started, 12)["state"] == "off"


def test_a_fault_during_pwm_sends_no_fault_message(started: Bench) -> None:
    started.replay("""
        > 60C 2B 09 20 01 02 05 00 00
        < 58C 60 09 20 01 00 00 00 00
        blow_fuse 13
        < -
        > 60C 40 08 20 03 00 00 00 00
        < 58C 4B 08 20 03 00 10 00 00
    """)


# -- NMT and fail-safe decisions ------------------------------------------------------------------

def test_stop_switches_outputs_off_pre_operational_keeps_them(started: Bench) -> None:
    started.replay("> 20C 00 00 03 00 00 00 00 00\n> 000 80 0C")
    assert pin(started, 1)["state"] == "high"
    started.replay("> 000 02 0C")
    assert pin(started, 1)["state"] == "off"


@pytest.mark.parametrize("reset", ["81", "82"])
def test_resets_start_with_outputs_off(started: Bench, reset: str) -> None:
    started.replay(f"> 20C 00 00 03 00 00 00 00 00\n> 000 {reset} 0C\n< 70C 00")
    assert pin(started, 1)["state"] == "off"


def test_power_cycle_clears_fault_latches_keeps_blown_fuses(started: Bench) -> None:
    started.replay("> 20C 00 00 01 00 00 00 00 00\nblow_fuse 1\n< 18C 01 00 00 00 00 00 00 00")
    started.replay("off\non\n< 70C 00")
    assert pin(started, 1)["state"] == "off"
    assert pin(started, 1)["fuse"] == "blown"


# -- consumer heartbeat (KBX §28 notes 1-3) -------------------------------------------------------

def test_heartbeat_loss_switches_off_and_holds_pre_operational(started: Bench) -> None:
    started.replay("""
        > 60C 23 16 10 01 64 00 01 00    # 100 ms from node 01h
        < 58C 60 16 10 01 00 00 00 00
        > 20C 00 00 01 00 00 00 00 00
        wait 0.5                         # monitoring starts at the first heartbeat only
        > 701 05
        wait 0.09
        > 701 05
        wait 0.09
    """)
    snapshot = started.twin.snapshot()
    assert snapshot["heartbeat_consumer"]["state"] == "active"
    assert snapshot["nmt_state"] == "operational"
    started.replay("wait 0.02")
    snapshot = started.twin.snapshot()
    assert (snapshot["heartbeat_consumer"]["state"], snapshot["nmt_state"]) == (
        "lost", "pre-operational")
    assert pin(started, 1)["state"] == "off"
    started.replay("> 701 05\nwait 0.05\n> 701 05")  # the producer is back
    assert started.twin.snapshot()["nmt_state"] == "pre-operational"
    started.replay("> 000 01 0C")
    assert started.twin.snapshot()["nmt_state"] == "operational"


def test_consumer_time_below_the_producer_time_never_stays_operational(started: Bench) -> None:
    started.replay("""
        > 60C 23 16 10 01 32 00 01 00    # 50 ms consumer
        < 58C 60 16 10 01 00 00 00 00
        > 701 05
        > 000 01 0C
        wait 0.1                         # producer sends every 100 ms
        > 701 05
    """)
    assert started.twin.snapshot()["nmt_state"] == "pre-operational"


# -- settings -------------------------------------------------------------------------------------

def test_restore_defaults_applies_at_the_next_reset() -> None:
    bench = boot()
    bench.replay("""
        > 60C 2B 17 10 00 64 00 00 00
        < 58C 60 17 10 00 00 00 00 00
        > 60C 2F 11 20 00 22 00 00 00
        < 58C 60 11 20 00 00 00 00 00
        > 60C 23 11 10 01 6C 6F 61 64
        < 58C 43 11 10 01 00 00 00 00
        wait 0.1
        < 70C 7F                         # the running heartbeat goes on until the reset
        > 000 81 0C
        < 70C 00                         # factory node id 0Ch, not 22h
        wait 1
        < -                              # heartbeat back to off
    """)


def test_node_id_applies_at_the_next_reset(started: Bench) -> None:
    started.replay("""
        > 60C 2F 11 20 00 16 00 00 00
        < 58C 60 11 20 00 00 00 00 00
        > 000 81 0C
        < 716 00
        > 616 40 00 10 00 00 00 00 00
        < 596 43 00 10 00 91 01 03 00
    """)


def test_settings_survive_the_process(tmp_path: Path) -> None:
    path = tmp_path / "keybox.json"
    first = Bench(KeyboxTwin(nvm=path))
    first.replay("""
        on
        < 70C 00
        > 60C 23 16 10 01 F4 01 01 00
        < 58C 60 16 10 01 00 00 00 00
        > 60C 2B 12 20 00 0A 00 00 00
        < 58C 60 12 20 00 00 00 00 00
    """)
    assert json.loads(path.read_text())["model"] == "keybox"
    first.twin.close()  # the process ends
    second = KeyboxTwin(nvm=path)
    second.power_on(0.0)
    assert second.snapshot()["heartbeat_consumer"] == {"node_id": 1, "time_ms": 500,
                                                       "state": "waiting"}
    assert second.snapshot()["fault_period_ms"] == 100


@pytest.mark.parametrize("bad", [0, 14])
def test_fault_injection_rejects_pins_outside_1_to_13(bad: int) -> None:
    with pytest.raises(ValueError, match=r"1\.\.13"):
        KeyboxTwin().blow_fuse(bad, 0.0)


def test_the_keypads_legacy_stop_is_not_a_keybox_command(started: Bench) -> None:
    started.replay("> 000 00 0C")
    assert started.twin.snapshot()["nmt_state"] == "operational"


def test_active_on_startup_and_no_boot_up() -> None:
    bench = boot()
    bench.replay("""
        > 60C 2F 13 20 00 01 00 00 00
        < 58C 60 13 20 00 00 00 00 00
        > 60C 2F 15 20 00 00 00 00 00
        < 58C 60 15 20 00 00 00 00 00
        off
        on
        < -
    """)
    assert bench.twin.snapshot()["nmt_state"] == "operational"


def test_bit_rate_codes_apply_at_the_next_reset() -> None:
    bench = boot()
    bench.replay("> 60C 2F 10 20 00 02 00 00 00\n< 58C 60 10 20 00 00 00 00 00")
    assert bench.twin.snapshot()["bitrate"] == 125_000
    bench.replay("> 000 81 0C\n< 70C 00")
    assert bench.twin.snapshot()["bitrate"] == 500_000  # errata B1: Keybox code 02h


def test_a_consumer_heartbeat_write_alone_is_stored(tmp_path: Path) -> None:
    path = tmp_path / "keybox.json"
    bench = Bench(KeyboxTwin(nvm=path))
    bench.replay("on\n< 70C 00\n> 60C 23 16 10 01 F4 01 01 00\n< 58C 60 16 10 01 00 00 00 00")
    assert json.loads(path.read_text())["settings"]["consumer_heartbeat_time"] == 0x000101F4
