"""scan on a busy bus: one identity reply lost after the device answered 1000h makes no
known device "other CANopen" and leaves no column blank (found by the newcomer/attacker pass
of session 4: `blinkcan scan` on a loaded machine listed the Keybox as "other CANopen")."""

from __future__ import annotations

import pytest

from blinkcan.devices.registry import describe_device, models
from blinkcan.host import scan
from blinkcan.protocol import Frame
from blinkcan.testing import Rig
from blinkcan.twin.registry import build_twin


@pytest.mark.parametrize("name", [m.name for m in models()])
@pytest.mark.parametrize("index", [0x1018, 0x100B, 0x1009, 0x100A])
def test_a_lost_identity_reply_is_asked_again(name: str, index: int) -> None:
    description = describe_device(name)
    node = 0x20
    lost: list[Frame] = []

    def first_reply_to(frame: Frame) -> bool:  # the device's first answer about ``index``
        if (not lost and frame.can_id == 0x580 + node and frame.data[0] >> 5 in (1, 2)
                and int.from_bytes(frame.data[1:3], "little") == index):
            lost.append(frame)
            return True
        return False

    with Rig() as rig:
        rig.add(build_twin(name, node_id=node))
        rig.drop(first_reply_to)
        found = scan(rig.bus, node_ids=range(node, node + 1))
    assert lost, "the test lost no reply"
    assert [(f.node_id, f.kind, f.model) for f in found] == [(node, description.kind, name)]
    identity = (found[0].vendor_id, found[0].model_id, found[0].hardware_version,
                found[0].software_version)
    assert None not in identity  # every column filled, the lost one asked again
