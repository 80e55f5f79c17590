"""Issue 17 item 9: outputs are restored only while the Keybox watches this host's heartbeat."""

from __future__ import annotations

from blinkcan.host import Keybox
from blinkcan.protocol import Frame
from blinkcan.testing import Rig
from blinkcan.twin import KeyboxTwin

HOST_HEARTBEAT = 0x77F


def _high(twin: KeyboxTwin) -> set[int]:
    return {pin["pin"] for pin in twin.snapshot()["pins"] if pin["state"] == "high"}


def _consumer(twin: KeyboxTwin) -> str:
    return str(twin.snapshot()["heartbeat_consumer"]["state"])


def test_no_restore_while_the_host_heartbeat_is_stopped() -> None:
    with Rig() as rig:
        twin = rig.add(KeyboxTwin(node_id=0x0C))
        box = Keybox(rig.bus, 0x0C, watchdog=0.1, restore_outputs=True)
        trips: list[str] = []
        box.on_health(lambda event: trips.append(event.kind))
        box.set_outputs(high=[3, 5])
        rig.advance(0.5)  # the Keybox heard the host: it watches
        box.stop_host_heartbeat()  # the application stops it
        rig.advance(0.5)
        assert "watchdog" in trips  # the Keybox switched off ...
        for _ in range(20):  # ... and nothing switches it back on while nobody watches
            rig.advance(0.5)
            assert _high(twin) == set()
        assert box.commanded == {3, 5}  # what the application asked is kept
        box.watch_host(0.1)  # the heartbeat is back
        rig.advance(0.5)
        assert _high(twin) == {3, 5}  # restored, and watched
        assert _consumer(twin) == "active"
        box.close()


def test_after_a_reboot_outputs_come_back_only_after_a_host_heartbeat() -> None:
    with Rig() as rig:
        twin = rig.add(KeyboxTwin(node_id=0x0C))
        box = Keybox(rig.bus, 0x0C, watchdog=0.1, restore_outputs=True)
        box.on(4)
        rig.advance(0.5)
        start = rig.now
        rig.power_cycle(twin)  # it boots watching for the host's first heartbeat (KBX §28)
        rig.advance(1.0)
        assert _high(twin) == {4}
        assert _consumer(twin) == "active"
        after = [(t, f) for t, f in rig.frames if t >= start]
        boot_up = next(t for t, f in after if f == Frame(0x70C, b"\x00"))
        restore = next(t for t, f in after if f == Frame(0x60C, bytes.fromhex(
            "2B08200208000000")))
        heartbeats = [t for t, f in after if f.can_id == HOST_HEARTBEAT and t > boot_up]
        assert heartbeats[0] <= restore  # the Keybox was watching when 4 went back on
        box.close()
