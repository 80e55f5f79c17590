"""Frame <-> python-can Message, and opening buses the way python-can's own tools do."""

from __future__ import annotations

from typing import Any

import can

from blinkcan.protocol.frame import Frame


def to_message(frame: Frame, timestamp: float = 0.0) -> can.Message:
    return can.Message(
        arbitration_id=frame.can_id,
        data=frame.data,
        is_extended_id=frame.extended,
        timestamp=timestamp,
        check=False,
    )


def to_frame(message: can.Message) -> Frame | None:
    """A data frame as :class:`Frame`; None for remote, error and CAN FD frames over 8 bytes."""
    if message.is_error_frame or message.is_remote_frame or message.dlc > 8:
        return None
    data = message.data
    if len(data) > 8:
        return None
    # python-can checked the identifier; Frame.trusted skips checking it again
    return Frame.trusted(message.arbitration_id, bytes(data), message.is_extended_id)


def open_bus(interface: str | None = None, channel: str | None = None,
             bitrate: int | None = None, **kwargs: Any) -> can.BusABC:
    """A python-can bus. With no interface named, python-can's configuration (file or
    environment) decides; with none configured either, a ``virtual`` bus on channel
    ``blinkcan``."""
    config: dict[str, Any] = dict(kwargs)
    if channel is not None:
        config["channel"] = channel
    if bitrate is not None:
        config["bitrate"] = bitrate
    if interface is None:
        try:
            can.util.load_config(config=dict(config))
        except can.CanInterfaceNotImplementedError:
            interface = "virtual"
            config.setdefault("channel", "blinkcan")
    if interface is not None:
        config["interface"] = interface
    if config.get("interface") == "virtual":
        config.setdefault("channel", "blinkcan")
    return can.Bus(**config)
