"""The bus options every command shares, named as python-can's own tools name them."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, TypeVar

import can
import click

from blinkcan.runtime import open_bus

F = TypeVar("F", bound=Callable[..., Any])


def bus_options(function: F) -> F:
    """--interface/-i, --channel/-c, --bitrate/-b; unset ones come from python-can's config."""
    function = click.option("-b", "--bitrate", type=int, default=None,
                            help="Bit rate in bit/s (python-can config if unset).")(function)
    function = click.option("-c", "--channel", default=None,
                            help="Channel, e.g. can0 or a virtual channel name.")(function)
    return click.option("-i", "--interface", default=None,
                            help="python-can interface (socketcan, pcan, kvaser, slcan, "
                                 "udp_multicast, virtual, ...). Default: python-can's "
                                 "configuration, else virtual.")(function)


def cli_bus(interface: str | None, channel: str | None, bitrate: int | None) -> can.BusABC:
    """The bus the options name; a bus that cannot be opened is one clear line, not a trace."""
    try:
        return open_bus(interface, channel, bitrate)
    except (can.CanError, ValueError, ImportError, OSError) as error:
        raise click.ClickException(f"cannot open the bus: {error}") from None


def parse_int(text: str) -> int:
    """A number as engineers write it: 21, 0x15 or 15h."""
    cleaned = text.strip().lower()
    try:
        if cleaned.endswith("h"):
            return int(cleaned[:-1], 16)
        return int(cleaned, 0)
    except ValueError:
        raise click.BadParameter(f"{text!r} is not a number (21, 0x15 or 15h)") from None
