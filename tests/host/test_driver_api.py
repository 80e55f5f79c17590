"""A driver class builds on ``host.device.Device`` through its public face only (issue 19): the
frames it listens to, what it releases at close, the PDOs it builds, and the hooks it
overrides. Checked for every registered model with a driver class of its own making."""

from __future__ import annotations

import pytest

from blinkcan.devices.model import DeviceDescription
from blinkcan.devices.registry import models
from blinkcan.host.device import Device, confirm_or_close
from blinkcan.protocol.cob import SDO_TX
from blinkcan.protocol.frame import Frame
from blinkcan.protocol.nmt import NmtCommand, NmtState
from blinkcan.testing import Rig
from blinkcan.twin.registry import build_twin


class Watching(Device):
    """A driver class as a new model's would be: no private attribute of Device used."""

    def __init__(self, rig: Rig, node_id: int, description: DeviceDescription) -> None:
        super().__init__(rig.bus, node_id, description)
        self.replies: list[Frame] = []
        self.hooks: list[object] = []
        self.released = False
        self.listen(SDO_TX + node_id, lambda frame, now: self.replies.append(frame))
        self.on_close(self._release)
        confirm_or_close(self, verify=True)

    def _release(self) -> None:
        self.released = True

    def nmt_command_seen(self, command: NmtCommand) -> None:
        self.hooks.append(command)

    def state_reported(self, state: NmtState, now: float) -> None:
        self.hooks.append(state)

    def booted_up(self, now: float) -> None:
        self.hooks.append("boot-up")


@pytest.mark.parametrize("name", [found.name for found in models()])
def test_a_driver_class_needs_only_the_public_face_of_device(name: str) -> None:
    rig = Rig()
    try:
        twin = rig.add(build_twin(name))
        node = twin.node_id
        driver = Watching(rig, node, twin.description)
        assert driver.confirmed
        assert driver.replies  # the replies to the identity reads (1000h, 1018h/01, 100Bh)
        assert {frame.can_id for frame in driver.replies} == {SDO_TX + node}
        driver.monitor_heartbeat(0.1)
        driver.start()
        rig.advance(0.25)  # a heartbeat reports the state the command asked for
        rig.power_cycle(twin)
        rig.settle()
        assert driver.hooks[:2] == [NmtCommand.START, NmtState.OPERATIONAL]
        assert "boot-up" in driver.hooks
        pdo = twin.description.pdos[0]
        assert driver.pdo_frame(pdo.name, {}).can_id == pdo.cob_id(node)
        assert driver.health_id == node
        driver.close()
        assert driver.released
    finally:
        rig.close()
