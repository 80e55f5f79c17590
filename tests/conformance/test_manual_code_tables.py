"""The manuals' baud-rate code tables (object 2010h), code by code, on every registered model.

PKP-2600-SI §19 (rev 1.5 §20), PKP-3500-MT §26 and the PKP-2400-SI's p. 18 print one table;
the Keybox §23 another (errata B1). A code applies at the next reset (CiA 301; errata B1), and a
code outside the table is refused with 0609 0030h (B1). The tables are written here as the
manuals print them, keyed by the registry's model and generation (a guard requires every
registered one), so a description that drifts from its manual fails here and not on a bus.
"""

from __future__ import annotations

import pytest

from blinkcan.devices.registry import models, parse_spec
from tests.twin.trace import factory_bench

#: PKP §19: "00h 1000k, 01h Reserved (force to 125k), 02h 500k, 03h 250k, 04h 125k (Default),
#: 05h Reserved (force to 125k), 06h 50k, 07h 20k"
KEYPAD_CODES = {0x00: 1_000_000, 0x01: 125_000, 0x02: 500_000, 0x03: 250_000, 0x04: 125_000,
                0x05: 125_000, 0x06: 50_000, 0x07: 20_000}
#: KBX §23: "00h: 125k (default) 01h: 250k 02h: 500k"
KEYBOX_CODES = {0x00: 125_000, 0x01: 250_000, 0x02: 500_000}

#: spec -> (its manual's table, where it is printed or what it is inferred from)
TABLES: dict[str, tuple[dict[int, int], str]] = {
    "pkp-2600-si@1.1": (KEYPAD_CODES, "printed"),
    "pkp-2600-si@1.5": (KEYPAD_CODES, "printed"),
    "pkp-3500-mt@1.3": (KEYPAD_CODES, "printed"),
    "keybox@1.0": (KEYBOX_CODES, "printed"),
    "pkp-2400-si@2": (KEYPAD_CODES, "printed"),  # pkp-2400-si-canopen.md: p. 18
    "pkp-2200-si@2": (KEYPAD_CODES, "inferred-I-1"),  # 2010h page not found
    "pkp-2300-si@2": (KEYPAD_CODES, "inferred-I-1"),
    "pkp-2500-si@2": (KEYPAD_CODES, "inferred-I-1"),
    "pkp-3500-si@2": (KEYPAD_CODES, "inferred-I-1"),
}


def test_every_registered_model_generation_has_its_code_table() -> None:
    assert {f"{m.name}@{g}" for m in models() for g in m.generations} == set(TABLES)


@pytest.mark.parametrize("spec", list(TABLES))
def test_the_description_carries_its_manuals_table(spec: str) -> None:
    found, generation = parse_spec(spec)
    assert found.description(generation).bitrates == TABLES[spec][0]


@pytest.mark.parametrize(("spec", "code", "bitrate"), [
    pytest.param(spec, code, rate, id=f"{spec}-{code:02X}h-{rate // 1000}k-{source}")
    for spec, (table, source) in TABLES.items() for code, rate in table.items()])
def test_each_code_runs_its_bit_rate_from_the_next_reset(spec: str, code: int,
                                                         bitrate: int) -> None:
    bench, node = factory_bench(spec)
    before = bench.twin.snapshot()["bitrate"]
    bench.replay(f"> {0x600 + node:X} 2F 10 20 00 {code:02X} 00 00 00\n"
                 f"< {0x580 + node:X} 60 10 20 00 00 00 00 00")
    assert bench.twin.snapshot()["bitrate"] == before  # not before the reset
    bench.replay(f"> 000 81 {node:02X}\n< {0x700 + node:X} 00")
    assert bench.twin.snapshot()["bitrate"] == bitrate
    bench.replay(f"> {0x600 + node:X} 40 10 20 00 00 00 00 00\n"
                 f"< {0x580 + node:X} 4F 10 20 00 {code:02X} 00 00 00")  # stored as written


@pytest.mark.parametrize("spec", list(TABLES))
def test_the_first_code_past_the_table_is_refused(spec: str) -> None:
    bench, node = factory_bench(spec)
    code = max(TABLES[spec][0]) + 1
    bench.replay(f"> {0x600 + node:X} 2F 10 20 00 {code:02X} 00 00 00\n"
                 f"< {0x580 + node:X} 80 10 20 00 30 00 09 06")  # errata B1
