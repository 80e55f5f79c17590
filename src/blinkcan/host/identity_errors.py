"""The errors that say the device answering at a node id is not the one a driver expects: here,
below both the SDO channel (which hears a second device's replies, host/sdo.py) and the drivers
(which compare what answers with their description, host/device.py)."""

from __future__ import annotations

from blinkcan.errors import BlinkcanError


class IdentityError(BlinkcanError):
    """The device at a node id is not the one the driver drives."""


class SharedNodeIdError(IdentityError):
    """More than one device answers at the node id: every SDO request gets a reply from each,
    and no driver can tell whose is whose. Give each device its own node id. ``answers``: the
    replies one request got."""

    def __init__(self, message: str, answers: int = 2) -> None:
        super().__init__(message)
        self.answers = answers


def several_answer(count: int, node_id: int) -> str:
    """"two devices answer at node 15h ..." for ``count`` replies to one request."""
    word = {2: "two", 3: "three", 4: "four"}.get(count, str(count))
    return (f"{word} devices answer at node {node_id:02X}h (one SDO request got {count} "
            "replies): give each device its own node id")
