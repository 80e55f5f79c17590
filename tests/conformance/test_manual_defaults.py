"""Every model's "Default settings" table, read back byte for byte from a factory twin.

Each manual opens with a table of the settings a device leaves the factory with (PKP-2600-SI
rev 1.1 §3, rev 1.5 §3, PKP-3500-MT §3, Keybox §10); the byte-padded siblings' spec files say
which of theirs were seen on a retrieved page and which are inferred (``I-n``: taken from the
PKP-2600-SI, named so in the case id). A case is one row: the SDO upload a host would send, and
the exact reply the row implies (command byte, value LSB first; ``??`` where the table says
nothing of a byte). The table is keyed by the registry's model and generation, and a guard
requires a table for every registered one, so a new model cannot skip its manual's defaults.
"""

from __future__ import annotations

from dataclasses import dataclass

import pytest

from blinkcan.devices.registry import models
from tests.twin.trace import factory_bench


@dataclass(frozen=True)
class Default:
    """One row of a defaults table: ``index``/``sub`` read back as ``reply`` (the command
    byte and the value bytes as they follow the multiplexer), ``source`` naming where it is
    printed, or the inference it rests on."""

    setting: str
    index: int
    sub: int
    reply: str
    source: str


#: PKP-2600-SI rev 1.1 §3 (the rows every CANopen keypad of the family shares)
_KEYPAD = (
    Default("baud rate 125 kbit/s", 0x2010, 0, "4F 04", "§3, §19: 04h 125k (default)"),
    Default("node id 15h", 0x2013, 0, "4F 15", "§3"),
    Default("not active on startup", 0x2012, 0, "4F 00", "§3"),
    Default("key brightness 3Fh", 0x2003, 1, "4F 3F", "§3"),
    Default("startup key brightness 3Fh", 0x2003, 5, "4F 3F", "§3, §18e"),
    Default("backlight off", 0x2003, 2, "4F 00", "§3"),
    Default("startup backlight off", 0x2003, 6, "4F 00", "§3, §18f"),
    Default("backlight colour amber", 0x2003, 3, "4F 08", "§3; §18c 08h amber/orange"),
    Default("default backlight colour amber", 0x2003, 4, "4F 08", "§3, §18d"),
    Default("complete LED show", 0x2014, 0, "4F 01", "§3; §23 01h (default)"),
    Default("periodic state transmission off", 0x1800, 5, "4B 00 00", "§3; errata P3: 4Bh"),
    Default("DEMO mode off", 0x2100, 0, "4F 00", "§3"),
    Default("heartbeat off", 0x1017, 0, "4B 00 00", "§3"),
    Default("boot-up service active", 0x2011, 0, "4F 01", "§3"),
)

#: rev 1.5 §3 adds the consumer heartbeat and the PDO transmission types
_REV15 = (
    *_KEYPAD,
    Default("heartbeat consumer off", 0x1016, 1, "43 00 00 ?? ??", "rev 1.5 §3; §26 time 0 = off"),
    Default("RPDO 200h asynchronous", 0x1400, 2, "4F FE", "rev 1.5 §3; §36 FEh"),
    Default("RPDO 300h asynchronous", 0x1401, 2, "4F FE", "rev 1.5 §3; §37 FEh"),
    Default("TPDO 180h event-driven", 0x1800, 2, "4F FE", "rev 1.5 §3; §44a FEh"),
)

#: PKP-3500-MT §3 (its brightness and colour rows are the 2600's, M56)
_MT = (
    *_REV15,
    Default("TPDO 480h every 80 ms", 0x2006, 0, "4F 08", "MT §3; §25 08h = 80 ms (M47)"),
    Default("startup tick counter 1 0000h", 0x2000, 3, "4B 00 00", "MT §3, §19c"),
    Default("startup tick counter 2 0000h", 0x2000, 5, "4B 00 00", "MT §3, §19e"),
    Default("TOP position encoder 1 08h", 0x2000, 6, "4F 08", "MT §3"),
    Default("TOP position encoder 2 08h", 0x2000, 7, "4F 08", "MT §3 (value cell blank, M35)"),
)

#: Keybox §10
_KEYBOX = (
    Default("baud rate 125 kbit/s", 0x2010, 0, "4F 00", "KBX §10; §23 00h 125k (default)"),
    Default("node id 0Ch", 0x2011, 0, "4F 0C", "KBX §10"),
    Default("pre-operational at start", 0x2013, 0, "4F 00", "KBX §10: not active on startup"),
    Default("periodic message off", 0x2012, 0, "4B 00 00", "KBX §10; errata K4: 0 = off"),
    Default("heartbeat off", 0x1017, 0, "4B 00 00", "KBX §10"),
    Default("boot-up service active", 0x2015, 0, "4F 01", "KBX §10; errata K13"),
)


def _sibling(seen: dict[int, str], inferred_from: dict[str, str]) -> tuple[Default, ...]:
    """A byte-padded sibling's rows: the PKP-2600-SI rev 1.5 table, each row named by what its
    spec file says of it: ``seen`` (index -> page) or inferred (``I-n`` -> the indices)."""
    rows = []
    for row in _REV15:
        if row.index in seen:
            source = f"seen: {seen[row.index]}"
        else:
            label = next((i for i, indices in inferred_from.items()
                          if f"{row.index:04X}" in indices.split()), "not seen, as 2600")
            source = f"inferred {label}"
        rows.append(Default(row.setting, row.index, row.sub, row.reply, source))
    return tuple(rows)


#: I-1 bit rate, I-6 heartbeat producer, I-7 start-up behaviour (pkp-2500-si-canopen.md, and
#: the same labels in pkp-3500-si-canopen.md)
_INFERRED = {"I-1": "2010", "I-6": "1017", "I-7": "2012 2003 2014 2100 2011"}

DEFAULTS: dict[str, tuple[Default, ...]] = {
    "pkp-2600-si@1.1": _KEYPAD,
    "pkp-2600-si@1.5": _REV15,
    "pkp-3500-mt@1.3": _MT,
    "keybox@1.0": _KEYBOX,
    "pkp-2200-si@2": _sibling({0x1400: "p. 25", 0x1401: "p. 26", 0x1800: "p. 31",
                               0x2013: "pp. 7-8 (15h in every identifier)"}, _INFERRED),
    "pkp-2300-si@2": _sibling({0x2013: "FR13 p. 16, 'default 15h'"}, _INFERRED),
    "pkp-2400-si@2": _sibling({0x2010: "p. 18, '04h 125k (Default)'"}, _INFERRED),
    "pkp-2500-si@2": _sibling({0x1016: "p. 22", 0x2013: "every identifier"}, _INFERRED),
    "pkp-3500-si@2": _sibling({0x2013: "p. 19, 'default 15h'"}, _INFERRED),
}


def _case_id(spec: str, row: Default) -> str:
    inferred = row.source.startswith(("inferred", "not seen"))
    tag = row.source.split(":", 1)[0].replace(" ", "-") if inferred else "printed"
    return f"{spec}-{row.index:04X}h{row.sub:02X}-{row.setting.replace(' ', '-')}-{tag}"


CASES = [pytest.param(spec, row, id=_case_id(spec, row))
         for spec, rows in DEFAULTS.items() for row in rows]


def test_every_registered_model_generation_has_its_defaults_table() -> None:
    registered = {f"{m.name}@{g}" for m in models() for g in m.generations}
    assert registered == set(DEFAULTS)


def _reply(row: Default) -> str:
    command, *value = row.reply.split()
    value += ["00"] * (4 - len(value))
    return f"{command} {row.index & 0xFF:02X} {row.index >> 8:02X} {row.sub:02X} {' '.join(value)}"


@pytest.mark.parametrize(("spec", "row"), CASES)
def test_a_factory_twin_reads_back_its_manuals_default(spec: str, row: Default) -> None:
    bench, node = factory_bench(spec)
    bench.replay(f"> {0x600 + node:X} 40 {row.index & 0xFF:02X} {row.index >> 8:02X} "
                 f"{row.sub:02X} 00 00 00 00\n< {0x580 + node:X} {_reply(row)}")


@pytest.mark.parametrize("spec", list(DEFAULTS))
def test_a_factory_twin_starts_pre_operational(spec: str) -> None:
    """Every table's node-state row: "Not active" on startup (KBX §10: pre-operational until
    an NMT start); the boot-up frame is sent (boot-up service active)."""
    bench, _ = factory_bench(spec)  # the boot-up frame is checked there
    assert bench.twin.snapshot()["nmt_state"] == "pre-operational"
