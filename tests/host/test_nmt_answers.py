"""Issue 17 item 8, in the drivers: only what a device says after an NMT command answers it."""

from __future__ import annotations

from blinkcan.host import HealthEvent, Keybox
from blinkcan.protocol.nmt import NmtState
from blinkcan.testing import Rig
from blinkcan.twin import KeyboxTwin


def test_a_heartbeat_sent_before_an_nmt_command_is_not_its_answer() -> None:
    with Rig(latency=0.1) as rig:  # every frame 0.1 s on the wire
        rig.add(KeyboxTwin(node_id=0x0C))
        box = Keybox(rig.bus, 0x0C, sdo_timeout=1.0)
        box.monitor_heartbeat(0.05)
        rig.advance(1.0)
        events: list[HealthEvent] = []
        box.on_health(events.append)
        box.enter_pre_operational()
        rig.advance(0.16)  # its "pre-operational" heartbeat is on the wire ...
        box.start()  # ... when the application starts it again
        rig.advance(1.0)
        assert [event.kind for event in events] == ["state", "state"]  # was: a "watchdog"
        assert box.nmt_state is NmtState.OPERATIONAL
        box.watch_host(0.1)  # a real trip is still one
        rig.advance(1.0)
        box.stop_host_heartbeat()
        rig.advance(1.0)
        assert "watchdog" in [event.kind for event in events]
        box.close()
