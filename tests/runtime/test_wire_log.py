"""The simulated wire's record: read as a list of TimedFrame, kept with no object per frame."""

from __future__ import annotations

import gc

from blinkcan.protocol import Frame
from blinkcan.runtime.wire_log import TimedFrame, WireLog
from blinkcan.testing import Rig
from blinkcan.twin import KeyboxTwin

A, B, C = Frame(0x181, b"\x01"), Frame(0x701, b"\x05"), Frame(0x000, b"\x01\x00")


def test_the_wire_log_reads_as_a_list_of_timed_frames() -> None:
    log = WireLog()
    expected = [TimedFrame(0.0, A), TimedFrame(0.01, B), TimedFrame(0.01, C)]
    for time, frame in expected:
        log.record(time, frame)
    assert len(log) == 3
    assert log == expected
    assert expected == log
    assert log != expected[:2]
    assert list(log) == expected
    assert log.copy() == expected
    assert log[0] == expected[0]
    assert log[-1].frame == C
    assert log[-1].time == 0.01
    assert log[1:] == expected[1:]
    assert log[::-1] == expected[::-1]
    assert log.since(0.005) == expected[1:]
    assert log.since(1.0) == []
    assert str(log[1]) == "  0.010000  Frame(701#05)"
    log.clear()
    assert log == []
    assert not log


def test_a_long_simulation_keeps_no_object_per_frame() -> None:
    """The record of a busy bus (14 Keyboxes, 10 ms heartbeat and fault PDO: 2,800 frames/s)
    grows no garbage-collected object per frame: the collector's full passes walked every
    record, about a quarter of such a simulation's time (issue 22)."""
    settings = {"producer_heartbeat_time": 10, "fault_period": 1, "active_on_startup": 1}
    with Rig() as rig:
        for node in range(1, 15):
            rig.add(KeyboxTwin(node_id=node, settings=settings))
        rig.advance(0.5)
        gc.collect()
        before, frames = len(gc.get_objects()), len(rig.frames)
        rig.advance(5.0)
        gc.collect()
        grown, sent = len(gc.get_objects()) - before, len(rig.frames) - frames
    assert sent > 13_000
    assert grown < sent / 100, f"{grown} objects more after {sent} frames"


def test_the_wire_log_adds_to_a_list_as_the_list_it_replaced_did() -> None:
    log = WireLog()
    first, second = Frame(0x715, b"\x00"), Frame(0x195, b"\x01")
    log.record(0.0, first)
    log.record(0.5, second)
    earlier = [TimedFrame(-1.0, second)]
    assert log + earlier == [TimedFrame(0.0, first), TimedFrame(0.5, second), *earlier]
    assert earlier + log == [*earlier, TimedFrame(0.0, first), TimedFrame(0.5, second)]
