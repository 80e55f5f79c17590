"""The fast rows of device frames (fleet/frames.py: a PDO's frames rowed from their bytes by
EventRows' followers with no Event, heartbeats and frames too short for their PDO kept by
their bytes, key states by their keys and the keys held before, the rows of events the decoder
keeps kept by Decoder.is_kept and Decoder.kept_event) are those of the
generic Event path (every frame decoded, its event's fields made rows by EventRows.rows),
row for row and value for value: on the realistic log (every model, J1939 too), on mixes of
each model's frames that change state (a reboot, a model learned mid-block, LED pictures, key
presses, releases and holds, outputs and faults), and on random data of every registered
model's PDO layouts (full length, shorter, longer)."""

from __future__ import annotations

import random
from pathlib import Path
from typing import Any

import pytest
from benchmarks.realistic_log import device_nodes, realistic_traffic, write_candump
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from blinkcan.decode.decoder import Decoder, Event
from blinkcan.decode.nodes import ModelsByNode
from blinkcan.devices.keypad_j1939 import COMMANDS, PRIORITY
from blinkcan.devices.registry import describe_device, models
from blinkcan.fleet import frames as fleet_frames
from blinkcan.fleet.frames import FrameDecoder, Segment
from blinkcan.fleet.sources import read_columns
from blinkcan.fleet.task import make_decoder
from blinkcan.protocol import Frame
from blinkcan.protocol.cob import HEARTBEAT, NMT, SDO_RX, SDO_TX
from blinkcan.protocol.j1939 import GLOBAL_ADDRESS, PGN_PROPRIETARY_A, compose_id
from blinkcan.twin import KeypadTwin
from tests.fleet.logs import EPOCH, candump_lines


def _segments(log: Path, fast: bool, limit: int, block_chars: int,
              devices: ModelsByNode | None) -> tuple[list[Any], int]:
    """Every row group's rows as plain values, and how many frames the decoder decoded."""
    decoder = make_decoder(devices)
    decoded = 0
    decode = decoder.decode

    def counting(frame: Frame, time: float = 0.0) -> Event:
        nonlocal decoded
        decoded += 1
        return decode(frame, time)

    decoder.decode = counting  # type: ignore[method-assign]
    frames = FrameDecoder(decoder)
    frames.fast = fast
    found: list[Any] = []
    segment = Segment()

    def shown(segment: Segment) -> Any:
        return ([array.to_pylist() for array in segment.frame_arrays()], segment.nodes,
                segment.models, segment.texts, [segment.details[c] for c in segment.codes],
                segment.frame_rows())

    for block in read_columns(log, block_chars=block_chars):
        position = 0
        while position < len(block):
            position = frames.decode(block, position, segment, limit)
            if segment.rows >= limit:
                found.append(shown(segment))
                segment = Segment()
    found.append(shown(segment))
    return found, decoded


def _assert_fast_as_generic(log: Path, limit: int, block_chars: int,
                            devices: ModelsByNode | None) -> tuple[int, int]:
    """The fast rows and the generic Event path's are the same; the decodes of both."""
    fast, fewer = _segments(log, True, limit, block_chars, devices)
    every, decoded = _segments(log, False, limit, block_chars, devices)
    assert len(fast) == len(every)
    for number, (ours, reference) in enumerate(zip(fast, every, strict=True)):
        for column, (mine, theirs) in enumerate(zip(ours, reference, strict=True)):
            assert mine == theirs, (number, column)
    return fewer, decoded


@pytest.mark.parametrize("limit", [97, 1 << 16])
def test_the_realistic_log_reads_the_same_fast(tmp_path: Path, limit: int) -> None:
    """Every model's traffic and a J1939 keypad's, other ECUs' frames: the PDOs rowed from
    their bytes and the heartbeats kept are no longer decoded."""
    log = tmp_path / "unit.log"
    write_candump(log, realistic_traffic(20_000))
    fewer, decoded = _assert_fast_as_generic(log, limit, 1 << 16, device_nodes())
    assert fewer < decoded * 0.85  # PDOs rowed from their bytes are not decoded


def test_the_realistic_log_reads_the_same_with_small_caches(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """What the fleet keeps of frames (the rows of kept SDO and J1939 events, key states,
    texts) starts over every few entries while the decoder's own kept entries stay: those
    entries' rows are made again, from the entry (fleet/frames.py _decode_arrow), not
    decoded."""
    monkeypatch.setattr(fleet_frames, "_ROWS_KEPT", 3)
    monkeypatch.setattr(fleet_frames, "_TEXTS_KEPT", 3)
    log = tmp_path / "unit.log"
    write_candump(log, realistic_traffic(20_000))
    fewer, decoded = _assert_fast_as_generic(log, 1 << 16, 1 << 16, device_nodes())
    assert fewer < decoded * 0.85


def test_an_sdo_read_kept_from_a_block_read_line_by_line(tmp_path: Path) -> None:
    """An SDO read and its value first met in a block read line by line (a remote frame in
    it), then again in blocks read whole: the decoder's kept entries, with nothing made of
    them yet, are rowed from the entry (CiA 301 §7.2.4.3.6; 1017h, the heartbeat producer
    time: no identity object, whose values are not kept)."""
    read = Frame(SDO_RX + 0x15, bytes((0x40, 0x17, 0x10, 0x00, 0, 0, 0, 0)))
    value = Frame(SDO_TX + 0x15, bytes((0x4B, 0x17, 0x10, 0x00, 0xE8, 0x03, 0, 0)))
    lines = [f"({EPOCH:.6f}) can0 715#R\n"]
    for n in range(40):
        lines += candump_lines([(EPOCH + n, read), (EPOCH + n + 0.001, value)])
    log = tmp_path / "sdo.log"
    log.write_text("".join(lines))
    fewer, decoded = _assert_fast_as_generic(log, 1 << 16, 200, {0x15: "keypad"})
    assert fewer < decoded


def _pool(model: Any, node: int, chance: random.Random) -> list[list[Frame]]:
    """Steps of a mix: each a frame or two of the model's traffic, from few values (so that
    frames repeat, from the same state and from another)."""
    description = describe_device(model.name)
    steps: list[list[Frame]] = []
    for layout in description.pdos:
        for _ in range(3):
            values = {s.name: chance.choice((0, 1, 2, 5, (1 << s.length) - 1)) & (
                (1 << s.length) - 1) for s in layout.signals}
            steps.append([Frame(layout.cob_id(node), layout.encode(values))])
    device_type = description.table["device_type"].default
    assert isinstance(device_type, int)
    steps += [
        [Frame(HEARTBEAT + node, b"\x05")], [Frame(HEARTBEAT + node, b"\x7f")],
        [Frame(HEARTBEAT + node, b"\x00")],  # a reboot: LEDs dark, outputs OFF, keys up
        [Frame(NMT, bytes((0x01, node)))],
        # the identity (CiA 301 §7.2.4.3.6): names an unknown node's model mid-block
        [Frame(SDO_RX + node, bytes((0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0))),
         Frame(SDO_TX + node, bytes((0x43, 0x00, 0x10, 0x00)) + device_type.to_bytes(
             4, "little"))],
        [Frame(0x7E0, b"\x02\x01\x0c")], [Frame(0x18FEF100, bytes(8), extended=True)]]
    j1939 = KeypadTwin(protocol="j1939")
    for key in (1, 2):  # the J1939 keypad's key messages (PKP-2600-SI J1939 §18)
        steps += [j1939.press(key, 0.0), j1939.release(key, 0.1)]
    return steps


@pytest.mark.parametrize("model", models(), ids=lambda model: model.name)
@given(seed=st.integers(0, 2**32 - 1),
       picks=st.lists(st.tuples(st.integers(0, 10**6), st.integers(1, 3)), min_size=1,
                      max_size=150),
       limit=st.integers(1, 60), known=st.booleans())
@settings(max_examples=12, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
def test_random_mixes_of_a_model_read_the_same_fast(
        tmp_path_factory: pytest.TempPathFactory, model: Any, seed: int,
        picks: list[tuple[int, int]], limit: int, known: bool) -> None:
    """The model named, or learned from its identity somewhere in the mix; steps taken once
    or a few times in a row (a frame again from the state it left)."""
    node = 0x15 if model.default_node_id != 0x15 else 0x16
    pool = _pool(model, node, random.Random(seed))
    traffic: list[tuple[float, Frame]] = []
    steps = [pick for pick, times in picks for _ in range(times)]
    for pick in [*range(len(pool)), *steps]:  # every step once, then the mix
        traffic += [(EPOCH + len(traffic) * 0.001, frame) for frame in pool[pick % len(pool)]]
    log = tmp_path_factory.mktemp("mix") / "mix.log"
    log.write_text("".join(candump_lines(traffic)))
    _assert_fast_as_generic(log, limit, 1_500, {node: model.name} if known else None)


@pytest.mark.parametrize("model", models(), ids=lambda model: model.name)
@given(data=st.data(), limit=st.integers(1, 80), known=st.booleans())
@settings(max_examples=15, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
def test_random_data_of_every_layout_reads_the_same_fast(
        tmp_path_factory: pytest.TempPathFactory, model: Any, data: st.DataObject,
        limit: int, known: bool) -> None:
    """Every PDO layout of the model with random bytes (most of its full length, some
    shorter or longer), among heartbeats of random states (a boot-up now and then) and
    the identity that names the model: the fast rows are the Event path's."""
    node = 0x15 if model.default_node_id != 0x15 else 0x16
    description = describe_device(model.name)
    device_type = description.table["device_type"].default
    assert isinstance(device_type, int)
    identity = [Frame(SDO_RX + node, bytes((0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0))),
                Frame(SDO_TX + node, bytes((0x43, 0x00, 0x10, 0x00)) +
                      device_type.to_bytes(4, "little"))]
    layouts = st.sampled_from(description.pdos)
    lengths = st.sampled_from(("full", "full", "full", "short", "long"))
    traffic: list[tuple[float, Frame]] = []
    for _ in range(data.draw(st.integers(1, 120), label="frames")):
        what = data.draw(st.integers(0, 9), label="what")
        frames: list[Frame]
        if what == 0:  # a heartbeat of any state (00h: a boot-up)
            frames = [Frame(HEARTBEAT + node, bytes((data.draw(
                st.sampled_from((0x00, 0x04, 0x05, 0x7F, 0x42)), label="state"),)))]
        elif what == 1:
            frames = identity
        else:
            layout = data.draw(layouts, label="layout")
            size = {"full": layout.length, "short": data.draw(
                st.integers(0, max(layout.length - 1, 0)), label="short"),
                "long": 8}[data.draw(lengths, label="length")]
            frames = [Frame(layout.cob_id(node), data.draw(
                st.binary(min_size=size, max_size=size), label="bytes"))]
        traffic += [(EPOCH + len(traffic) * 0.001, frame) for frame in frames]
    log = tmp_path_factory.mktemp("random") / "random.log"
    log.write_text("".join(candump_lines(traffic)))
    _assert_fast_as_generic(log, limit, 1_500, {node: model.name} if known else None)


def test_a_frame_that_changes_state_is_decoded_each_time() -> None:
    """The decoder's word: a key state's event depends on the keys held before (PKP §10),
    a boot-up resets them; an SDO request starts a transfer (no state to keep it by)."""
    decoder = Decoder({0x15: "keypad"})
    keys = describe_device("keypad").pdo("key_state")
    pressed = Frame(keys.cob_id(0x15), keys.encode({"keys": 1, "tick": 0}))
    boot_up = Frame(HEARTBEAT + 0x15, b"\x00")
    for frame in (pressed, boot_up, Frame(SDO_RX + 0x15, bytes(8))):
        assert decoder.repeat_state(frame.can_id, frame.extended, frame.data) is None
        decoder.decode(frame)  # routed now
    before = decoder.repeat_state(pressed.can_id, False, pressed.data)
    decoder.decode(pressed)
    assert decoder.repeat_state(pressed.can_id, False, pressed.data) != before  # key 1 down
    held = decoder.repeat_state(boot_up.can_id, False, boot_up.data)
    decoder.decode(boot_up)
    assert decoder.repeat_state(boot_up.can_id, False, boot_up.data) != held  # keys reset
    assert decoder.repeat_state(SDO_RX + 0x15, False, bytes(8)) is None


def test_a_kept_j1939_frame_means_it_again_only_with_the_same_keypads(tmp_path: Path) -> None:
    """PKP-2600-SI J1939 §6 and §18: a command to all from an address that is no keypad is
    a command; once a key message shows that address is a keypad, the same frame is one the
    keypad sent (no command), so what the fleet kept of it (Decoder.kept_event) is not
    used again. Other J1939 and SDO frames kept between them."""
    twin = KeypadTwin(protocol="j1939")
    led = next(c for c in COMMANDS if c.name == "single_led")
    other = 0x30  # not a keypad address yet
    to_all = Frame(compose_id(PGN_PROPRIETARY_A, other, GLOBAL_ADDRESS, PRIORITY),
                   led.encode(1, 0, 1, 0), extended=True)
    twin.power_on(0.0)
    press = twin.press(3, 0.0)[0]
    from_other = Frame(press.can_id & ~0xFF | other, press.data, extended=True)
    read = Frame(SDO_RX + 0x15, bytes((0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0)))
    steps = [to_all, press, to_all, read, to_all, from_other, to_all, press, to_all, read]
    traffic = [(EPOCH + n * 0.001, frame) for n, frame in enumerate(steps * 2)]
    log = tmp_path / "j1939.log"
    log.write_text("".join(candump_lines(traffic)))
    for limit in (3, 1 << 16):
        fewer, decoded = _assert_fast_as_generic(log, limit, 1 << 16, {0x15: "keypad"})
        assert fewer < decoded  # kept frames were not decoded again
