"""scan on a loaded host: a device whose 1000h reply comes after the probe's window, or whose
reply is lost while its heartbeat is heard, is probed again and found (seen once at load 8-9:
the conformance suite's `scan` said "no device answered" for a Keybox that was there)."""

from __future__ import annotations

from collections.abc import Callable

import pytest

from blinkcan.devices.registry import models
from blinkcan.host import scan
from blinkcan.host.bus import HostBus
from blinkcan.protocol import Frame
from blinkcan.testing import Rig
from blinkcan.twin.registry import build_twin

NODE = 0x20


def _first_device_type_reply(taken: list[Frame]) -> Callable[[Frame], bool]:
    def match(frame: Frame) -> bool:  # the device's first answer about 1000h
        if (not taken and frame.can_id == 0x580 + NODE
                and int.from_bytes(frame.data[1:3], "little") == 0x1000):
            taken.append(frame)
            return True
        return False
    return match


@pytest.mark.parametrize("name", [m.name for m in models()])
def test_a_reply_after_the_window_is_probed_again(name: str) -> None:
    late: list[Frame] = []
    with Rig() as rig:
        rig.add(build_twin(name, node_id=NODE))
        rig.delay(_first_device_type_reply(late), 0.3)  # the probe's window is 0.2 s
        found = scan(rig.bus, node_ids=range(NODE, NODE + 2))
    assert late, "the test delayed no reply"
    assert [(f.node_id, f.model) for f in found] == [(NODE, name)]


@pytest.mark.parametrize("name", [m.name for m in models()])
def test_a_heard_device_whose_reply_is_lost_is_probed_again(name: str) -> None:
    lost: list[Frame] = []
    with Rig() as rig:
        rig.add(build_twin(name, node_id=NODE))
        host = HostBus.attach(rig.bus)
        host.sdo(NODE).download(0x1017, 0, (100).to_bytes(2, "little"))  # heartbeat each 100 ms
        host.release()
        rig.drop(_first_device_type_reply(lost))
        found = scan(rig.bus, node_ids=range(NODE, NODE + 1))
    assert lost, "the test lost no reply"
    assert [f.node_id for f in found] == [NODE]


def test_a_silent_node_is_probed_once() -> None:
    with Rig() as rig:
        start = rig.now
        assert scan(rig.bus, node_ids=range(NODE, NODE + 4)) == []
        assert rig.now - start == pytest.approx(0.3 + 4 * 0.2)  # listen, then one window each
