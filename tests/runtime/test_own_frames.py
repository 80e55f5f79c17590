"""A bus that echoes its own frames (python-can's udp_multicast): the echo of each frame sent
is recognised once, within the window, and nothing else is taken for one. The buses here are
stand-ins named as python-can's classes: no socket is opened, no datagram sent (a real one in
a test would take hop_limit=0)."""

from __future__ import annotations

from typing import cast

import can

from blinkcan.protocol import Frame
from blinkcan.runtime.canbus import OwnFrames


def _echoing() -> OwnFrames:
    class UdpMulticastBus:  # what echoes_own_frames recognises, with no socket
        pass

    return OwnFrames(cast(can.BusABC, UdpMulticastBus()), window=2.0)


def test_each_frame_sent_is_taken_for_an_echo_once_per_sending() -> None:
    own = _echoing()
    frame, other = Frame(0x615, bytes(8)), Frame(0x595, bytes(8))
    own.sent(frame, 1.0)
    own.sent(frame, 1.1)
    assert not own.is_echo(other, 1.2)
    assert own.is_echo(frame, 1.2)
    assert own.is_echo(frame, 1.2)
    assert not own.is_echo(frame, 1.2)  # a third equal frame is another node's


def test_an_echo_that_never_came_is_forgotten_after_the_window() -> None:
    own = _echoing()
    frame = Frame(0x615, bytes(8))
    own.sent(frame, 1.0)
    assert not own.is_echo(frame, 3.5)  # 2.5 s later: another node's frame
    own.sent(frame, 4.0)
    own.sent(frame, 5.5)
    assert own.is_echo(frame, 6.2)  # the one of 4.0 s is gone, the one of 5.5 s is this
    assert not own.is_echo(frame, 6.3)


def test_frames_sent_long_ago_are_no_echoes_of_anything_later() -> None:
    own = _echoing()
    for i in range(1000):
        own.sent(Frame(0x100 + i % 0x600, i.to_bytes(2, "little")), i * 0.01)
    assert not own.is_echo(Frame(0x100, b"\x00\x00"), 10.5)  # sent at 0 s
    assert own.is_echo(Frame(0x100 + 999 % 0x600, (999).to_bytes(2, "little")), 10.5)


def test_a_bus_that_does_not_echo_takes_nothing_for_an_echo() -> None:
    class VirtualBus:
        pass

    own = OwnFrames(cast(can.BusABC, VirtualBus()))
    frame = Frame(0x615, bytes(8))
    own.sent(frame, 1.0)
    assert not own.is_echo(frame, 1.0)
