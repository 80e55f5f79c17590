"""The retry count of SDO requests is checked as an argument, before anything is sent: an int,
0..MAX_SDO_RETRIES (found in session 9: nothing checked it; ``retries=-1`` ran no attempt and
raised AssertionError("unreachable"), 1.5 or "1" a TypeError from ``range`` naming no argument,
True passed as 1, and ``HostBus.sdo`` took any of them; the expedited read's fast path would
have sent the read before any of those errors)."""

from __future__ import annotations

from collections.abc import Callable

import pytest

from blinkcan.host import HostBus
from blinkcan.host.sdo import MAX_SDO_RETRIES, SdoChannel
from blinkcan.testing import Rig
from blinkcan.twin.registry import build_twin

BAD = [(-1, ValueError), (MAX_SDO_RETRIES + 1, ValueError), (1.5, TypeError),
       (True, TypeError), ("1", TypeError)]


def _calls(host: HostBus, node: int) -> dict[str, Callable[[object], object]]:
    """Every way a retry count reaches an SDO request."""
    sdo = host.sdo(node)
    return {
        "HostBus.sdo": lambda retries: host.sdo(node, 0.2, retries),
        "upload": lambda retries: sdo.upload(0x1000, 0, retries=retries),
        "download": lambda retries: sdo.download(
            0x1017, 0, b"\x00\x00", retries=retries),
        "channel upload": lambda retries: sdo.channel.upload(
            0x1000, 0, retries=retries),
        "channel download": lambda retries: sdo.channel.download(
            0x1017, 0, b"\x00\x00", retries=retries),
        "SdoChannel": lambda retries: SdoChannel(host, node, 0.2, retries),
    }


@pytest.mark.parametrize(("retries", "error"), BAD, ids=[repr(b[0]) for b in BAD])
@pytest.mark.parametrize("call", ["HostBus.sdo", "upload", "download", "channel upload",
                                  "channel download", "SdoChannel"])
def test_a_bad_retry_count_is_refused_before_anything_is_sent(
        call: str, retries: object, error: type[Exception]) -> None:
    rig = Rig()
    try:
        twin = rig.add(build_twin("keypad"))
        host = HostBus(rig.bus).start()
        sent = len(rig.frames)
        with pytest.raises(error, match="retries"):
            _calls(host, twin.node_id)[call](retries)
        assert [f for f in rig.frames[sent:] if f.frame.can_id == 0x600 + twin.node_id] == []
        host.stop()
    finally:
        rig.close()


@pytest.mark.parametrize("retries", [0, 1, MAX_SDO_RETRIES])
def test_a_good_retry_count_is_taken(retries: int) -> None:
    rig = Rig()
    try:
        twin = rig.add(build_twin("keypad"))
        host = HostBus(rig.bus).start()
        sdo = host.sdo(twin.node_id, 0.2, retries)
        assert sdo.retries == retries
        assert sdo.upload(0x1000, 0, retries=retries) == sdo.upload(0x1000, 0)
        host.stop()
    finally:
        rig.close()
