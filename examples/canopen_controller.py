"""A controller written with python-canopen: key N of the keypad toggles Keybox output N.

It uses python-canopen the way a CANopen master does, on any python-can bus: a ``Network`` on
the bus, a ``RemoteNode`` per device loaded from its EDS (``blinkcan export eds keypad`` /
``keybox``, or the files shipped in ``blinkcan/data``), SDO writes to configure them, NMT to
start them, PDO maps read from the devices to hear keys and faults and to switch outputs, and
the heartbeats as a consumer. Its tests (``examples/test_canopen_controller.py``) run it against
the twins on ``Rig().bus``, in simulated time.

The rules it follows, as a real master must:

- **Nothing blocks in a callback.** python-canopen calls PDO and heartbeat callbacks on its
  notifier's thread; an SDO request made there never hears its reply (that thread is busy).
  The callbacks only send PDOs and NMT commands (no reply awaited) and note what they saw.
- **The Keybox's outputs follow what the controller commanded, also after a reboot.** A Keybox
  that power-cycles boots with every output OFF and in PRE-OPERATIONAL; its boot-up heartbeat
  makes the controller start it again and send its outputs again.
- **A silent Keybox is noticed.** :meth:`supervise` waits for its heartbeat for three periods
  (python-canopen's ``wait_for_heartbeat``) and reports it lost otherwise.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import can
import canopen

from blinkcan.devices.registry import describe_device
from blinkcan.formats.shipped import shipped_eds

KEYPAD_EDS = Path(shipped_eds(describe_device("keypad")))
KEYBOX_EDS = Path(shipped_eds(describe_device("keybox")))
#: CiA 301 NMT state of a boot-up message
BOOT_UP = 0


def _node(network: canopen.Network, node_id: int, eds: Path) -> Any:
    """A ``RemoteNode`` on ``network`` with the objects its EDS names (python-canopen is
    untyped: Any)."""
    return network.add_node(node_id, str(eds))


class CanopenToggleController:
    """Key N toggles Keybox output N; a faulted output is noted and switched off."""

    def __init__(self, bus: can.BusABC, keypad_node: int = 0x15, keybox_node: int = 0x0C,
                 heartbeat_ms: int = 100) -> None:
        self.heartbeat = heartbeat_ms / 1000
        self.network = canopen.Network(bus)
        self.network.connect()
        self.keypad = _node(self.network, keypad_node, KEYPAD_EDS)
        self.keybox = _node(self.network, keybox_node, KEYBOX_EDS)
        self.commanded = 0  # bit N-1: output N switched HIGH by us
        self.faults: set[int] = set()
        self.keybox_lost = False
        self._pressed = 0
        for node in (self.keypad, self.keybox):
            node.sdo["Producer heartbeat time"].raw = heartbeat_ms  # SDO write
            node.tpdo.read()  # PDO configuration read by SDO, named by the EDS
        self.keybox.rpdo.read()
        self.keypad.tpdo[1].add_callback(self._on_keys)
        self.keybox.tpdo[1].add_callback(self._on_faults)
        self.keybox.nmt.add_heartbeat_callback(self._on_keybox_heartbeat)
        self.keypad.nmt.state = "OPERATIONAL"
        self.keybox.nmt.state = "OPERATIONAL"

    def vendor_id(self) -> int:
        """The Keybox's vendor id (an SDO read of 1018h sub 1)."""
        return int(self.keybox.sdo["Identity object"]["Vendor-ID"].raw)

    # -- callbacks: on python-canopen's notifier thread, never blocking ------------------------

    def _on_keys(self, pdo: Any) -> None:
        pressed = pdo["Digital input module, keys states.Keys pressed"].raw
        newly = pressed & ~self._pressed
        self._pressed = pressed
        if newly:
            self.commanded ^= newly
            self._send_outputs()

    def _on_faults(self, pdo: Any) -> None:
        faulted = pdo["Output state.Outputs FAULT"].raw
        self.faults = {pin for pin in range(1, 14) if faulted >> (pin - 1) & 1}
        if self.commanded & faulted:
            self.commanded &= ~faulted  # a blown output is not ours to keep on
            self._send_outputs()

    def _on_keybox_heartbeat(self, state: int) -> None:
        self.keybox_lost = False
        if state == BOOT_UP:  # rebooted: outputs OFF, PRE-OPERATIONAL
            self.keybox.nmt.state = "OPERATIONAL"
            self._send_outputs()

    def _send_outputs(self) -> None:
        outputs = self.keybox.rpdo[1]
        outputs["Output state.Outputs HIGH"].raw = self.commanded
        outputs["Output state.Outputs OFF"].raw = ~self.commanded & 0x1FFF
        outputs.transmit()

    # -- the main loop's work ----------------------------------------------------------------

    def supervise(self) -> bool:
        """Wait for the Keybox's next heartbeat, three periods at most; False (and
        ``keybox_lost``) when none came."""
        try:
            self.keybox.nmt.wait_for_heartbeat(timeout=3 * self.heartbeat)
        except canopen.nmt.NmtError:
            self.keybox_lost = True
        return not self.keybox_lost

    def close(self) -> None:
        self.network.disconnect()
