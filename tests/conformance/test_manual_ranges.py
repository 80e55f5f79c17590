"""The value ranges the manuals (and the errata rows that settle them) give for the settings
every model shares, written as each manual prints them and run on every registered model.

- Heartbeat producer 1017h: 0 = off, 10..65279 ms; 1..9 and above FEFFh are refused with
  0609 0030h (PKP errata P1, rev 1.5 §27, MT M66, PKP-2300 E3; siblings whose 1017h page is
  missing: I-6/I-11, named in the case id). The Keybox's own range is 1..65279 (KBX §29, K17).
- Node id: 01h..7Fh; 00h and 80h are refused (PKP P11 on 2013h; Keybox 2011h, §24).
- Brightness levels 2003h/01 and /02: 00h..3Fh; 40h is refused (PKP P15, MT §22).
- Transmission types (generation-2 keypads: rev 1.5 §36/§37/§44a, MT M69/M73, siblings): RPDO
  1400h/1401h sub 02h take 00h-F0h and FEh, TPDO 1800h sub 02h 01h-F0h and FEh; 00h (TPDO),
  F1h and FFh are refused (errata G3, MT M73, PKP-2200 S2).
A guard requires a row for every registered model and generation.
"""

from __future__ import annotations

from dataclasses import dataclass

import pytest

from blinkcan.devices.registry import models
from tests.twin.trace import Bench, factory_bench


@dataclass(frozen=True)
class Ranges:
    """What a model's manual gives: its node-id object, whether it has the keypad brightness
    levels and settable PDO transmission types, and where its 1017h range comes from."""

    node_id_index: int
    levels: bool
    sync_types: bool
    heartbeat_source: str
    heartbeat_min_ms: int = 10


_REV11 = Ranges(0x2013, levels=True, sync_types=False, heartbeat_source="P1")
_GEN2 = Ranges(0x2013, levels=True, sync_types=True, heartbeat_source="P1-rev15-s27")
_SIBLING = Ranges(0x2013, levels=True, sync_types=True, heartbeat_source="inferred-I-11")

RANGES: dict[str, Ranges] = {
    "pkp-2600-si@1.1": _REV11,
    "pkp-2600-si@1.5": _GEN2,
    "pkp-3500-mt@1.3": Ranges(0x2013, levels=True, sync_types=True, heartbeat_source="M66"),
    "keybox@1.0": Ranges(0x2011, levels=False, sync_types=False, heartbeat_source="K17",
                         heartbeat_min_ms=1),
    "pkp-2200-si@2": _SIBLING,
    "pkp-2300-si@2": Ranges(0x2013, levels=True, sync_types=True, heartbeat_source="E3"),
    "pkp-2400-si@2": _SIBLING,
    "pkp-2500-si@2": _SIBLING,
    "pkp-3500-si@2": _SIBLING,
}


def test_every_registered_model_generation_has_its_ranges() -> None:
    assert {f"{m.name}@{g}" for m in models() for g in m.generations} == set(RANGES)


def _booted(spec: str) -> tuple[Bench, str, str]:
    """The factory twin, and the COB-IDs of its SDO requests and replies."""
    bench, node = factory_bench(spec)
    return bench, f"{0x600 + node:X}", f"{0x580 + node:X}"


def _write(bench: Bench, request: str, reply: str, index: int, sub: int, command: str,
           value: str, accepted: bool) -> None:
    mux = f"{index & 0xFF:02X} {index >> 8:02X} {sub:02X}"
    data = (value.split() + ["00"] * 4)[:4]
    answer = f"60 {mux} 00 00 00 00" if accepted else f"80 {mux} 30 00 09 06"
    bench.replay(f"> {request} {command} {mux} {' '.join(data)}\n< {reply} {answer}")


def _cases(kind: str, values: list[tuple[str, bool | None]]) -> list[object]:
    """A case per model that has ``kind`` and per value (``None``: depends on the model)."""
    cases: list[object] = []
    for spec, ranges in RANGES.items():
        if kind != "heartbeat" and not getattr(ranges, kind):
            continue
        for value, printed in values:
            accepted = (int(value.split()[0], 16) >= ranges.heartbeat_min_ms
                        if printed is None else printed)
            outcome = "ok" if accepted else "refused"
            source = f"-{ranges.heartbeat_source}" if kind == "heartbeat" else ""
            cases.append(pytest.param(spec, value, accepted,
                                      id=f"{spec}-{value.replace(' ', '')}-{outcome}{source}"))
    return cases


@pytest.mark.parametrize(("spec", "value", "accepted"), _cases("heartbeat", [
    ("00 00", True), ("01 00", None), ("09 00", None), ("0A 00", True), ("FF FE", True),
    ("00 FF", False), ("FF FF", False)]))
def test_heartbeat_producer_time(spec: str, value: str, accepted: bool) -> None:
    bench, request, reply = _booted(spec)
    _write(bench, request, reply, 0x1017, 0, "2B", value, accepted)
    bench.pending = []  # a heartbeat it now sends is not this test's subject
    if accepted:
        bench.replay(f"> {request} 40 17 10 00 00 00 00 00\n< {reply} 4B 17 10 00 {value} 00 00")


@pytest.mark.parametrize(("spec", "value", "accepted"), [
    pytest.param(spec, value, False, id=f"{spec}-{value}-refused")
    for spec in RANGES for value in ("00", "80", "FF")])
def test_node_id_outside_01_to_7f_is_refused(spec: str, value: str, accepted: bool) -> None:
    bench, request, reply = _booted(spec)
    _write(bench, request, reply, RANGES[spec].node_id_index, 0, "2F", value, accepted)


@pytest.mark.parametrize(("spec", "value", "accepted"), _cases("levels", [
    ("00", True), ("3F", True), ("40", False), ("FF", False)]))
@pytest.mark.parametrize("sub", [1, 2])
def test_brightness_levels(spec: str, value: str, accepted: bool, sub: int) -> None:
    bench, request, reply = _booted(spec)
    _write(bench, request, reply, 0x2003, sub, "2F", value, accepted)
    if accepted:
        bench.replay(f"> {request} 40 03 20 {sub:02X} 00 00 00 00\n"
                     f"< {reply} 4F 03 20 {sub:02X} {value} 00 00 00")


@pytest.mark.parametrize(("spec", "value", "accepted"), _cases("sync_types", [
    ("00", True), ("01", True), ("F0", True), ("FE", True), ("F1", False), ("FD", False),
    ("FF", False)]))
@pytest.mark.parametrize("index", [0x1400, 0x1401])
def test_rpdo_transmission_types(spec: str, value: str, accepted: bool, index: int) -> None:
    bench, request, reply = _booted(spec)
    _write(bench, request, reply, index, 2, "2F", value, accepted)


@pytest.mark.parametrize(("spec", "value", "accepted"), _cases("sync_types", [
    ("00", False), ("01", True), ("F0", True), ("FE", True), ("F1", False), ("FF", False)]))
def test_tpdo_transmission_types(spec: str, value: str, accepted: bool) -> None:
    bench, request, reply = _booted(spec)
    _write(bench, request, reply, 0x1800, 2, "2F", value, accepted)


#: 1800h/05's lowest period other than 0 (off): 10 ms (errata P2, rev 1.5 §44b), the
#: PKP-3500-MT 50 ms (MT §50 "from 0032h", rev 1.2 "Updated timer range", M72)
PERIOD_MIN_MS = {"pkp-3500-mt@1.3": 50}


@pytest.mark.parametrize(("spec", "value", "accepted"), [
    pytest.param(spec, f"{ms & 0xFF:02X} {ms >> 8:02X}", accepted,
                 id=f"{spec}-{ms}ms-{'ok' if accepted else 'refused'}")
    for spec in RANGES if RANGES[spec].levels  # the keypads: KBX has no 1800h/05 (errata B3)
    for lowest in [PERIOD_MIN_MS.get(spec, 10)]
    for ms, accepted in ((0, True), (1, False), (lowest - 1, False), (lowest, True),
                         (0xFEFF, True), (0xFF00, False))])
def test_periodic_key_state_timer(spec: str, value: str, accepted: bool) -> None:
    """1800h/05, the key-state PDO's period: 0 = off, the lowest period..65279 ms."""
    bench, request, reply = _booted(spec)
    _write(bench, request, reply, 0x1800, 5, "2B", value, accepted)


@pytest.mark.parametrize(("spec", "entry", "accepted"), [
    pytest.param(spec, entry, accepted, id=f"{spec}-{entry.replace(' ', '')}-{why}")
    for spec in RANGES if RANGES[spec].sync_types  # the generation-2 keypads have 1016h
    for entry, accepted, why in (
        ("00 00 01 00", True, "off"), ("0A 00 01 00", True, "10ms-node-01"),
        ("00 00 00 00", False, "off-node-00"),  # G4: node 01h-7Fh, whatever the time
        ("FF FF 7F 00", True, "65535ms-node-7F"), ("09 00 01 00", False, "9ms"),
        ("64 00 00 00", False, "node-00"), ("64 00 15 00", False, "its-own-node"),
        ("64 00 80 00", False, "node-80"))])
def test_consumer_heartbeat_entry(spec: str, entry: str, accepted: bool) -> None:
    """1016h/01: time 0 = off or 10..65535 ms, a node 01h-7Fh other than the keypad's own
    (errata G4, rev 1.5 §26, MT M65, PKP-2500 A7; the others inferred I-11)."""
    bench, request, reply = _booted(spec)
    _write(bench, request, reply, 0x1016, 1, "23", entry, accepted)
