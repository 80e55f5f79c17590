"""The bus options every command shares, named as python-can's own tools name them:
``-i/--interface``, ``-c/--channel``, ``-b/--bitrate`` and ``--bus-kwargs NAME=VALUE ...``.

They are accepted by ``blinkcan`` itself, by the command groups and by every command that opens
a bus, so they work before or after the subcommand (``blinkcan -i socketcan -c can0 keypad led 3
red`` = ``blinkcan keypad led 3 red -i socketcan -c can0``). Each one given is recorded in the
click context's ``meta``, which the whole command line shares; the one nearest the command wins,
and ``--bus-kwargs`` accumulate.

With no interface named, python-can's configuration (file or environment) decides; with none
configured either, the command line uses ``udp_multicast`` on :data:`DEFAULT_GROUP`, port
:data:`DEFAULT_PORT`, with hop limit 0: IPv4 multicast with TTL 0 is delivered to the sockets of
this machine and never sent on a network, so ``blinkcan emulate`` in one terminal and ``blinkcan
scan`` in another find each other, and nothing leaves the machine. ``--bus-kwargs port=N
hop_limit=1`` changes port and reach. (The Python API's default stays python-can's in-process
``virtual`` bus.)
"""

from __future__ import annotations

import re
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any, TypeVar

import click

from blinkcan.cli.whole import Whole
from blinkcan.protocol.cob import check_node_id

if TYPE_CHECKING:  # python-can and the runtime load when a bus is opened (start-up: issue 22)
    import can

F = TypeVar("F", bound=Callable[..., Any])

#: the command line's own bus when none is configured: python-can's IPv4 default group and port
DEFAULT_INTERFACE = "udp_multicast"
DEFAULT_GROUP = "239.74.163.2"
DEFAULT_PORT = 43113
DEFAULT_HOP_LIMIT = 0
#: ISO 11898-1: a classical CAN bus (and CAN FD's arbitration phase) runs at 1 Mbit/s at most
MAX_BITRATE = 1_000_000

_META = "blinkcan.bus"
_BUS_KWARG = re.compile(r"(?P<name>[_a-zA-Z][_a-zA-Z0-9-]*)=(?P<value>\S*)")


def _settings(ctx: click.Context) -> dict[str, Any]:
    settings: dict[str, Any] = ctx.meta.setdefault(_META, {"kwargs": {}})
    return settings


def _remember(ctx: click.Context, param: click.Parameter, value: Any) -> None:
    if value is None or value == ():
        return
    if param.name == "bus_kwargs":
        _settings(ctx)["kwargs"].update(parse_bus_kwargs(value))
    else:
        _settings(ctx)[str(param.name)] = value


def parse_bus_kwargs(items: Sequence[str]) -> dict[str, Any]:
    """``NAME=VALUE`` items as python-can's ``--bus-kwargs`` reads them (numbers and booleans
    converted)."""
    from can.util import cast_from_string  # noqa: PLC0415 (start-up: only with --bus-kwargs)

    kwargs: dict[str, Any] = {}
    for item in items:
        match = _BUS_KWARG.fullmatch(item)
        if match is None:
            raise click.BadParameter(f"{item!r} is not NAME=VALUE", param_hint="--bus-kwargs")
        kwargs[match["name"].replace("-", "_")] = cast_from_string(match["value"])
    return kwargs


def spread_bus_kwargs(args: Sequence[str]) -> list[str]:
    """python-can's form ``--bus-kwargs a=1 b=2`` as click reads a repeated option:
    ``--bus-kwargs a=1 --bus-kwargs b=2``."""
    spread: list[str] = []
    index = 0
    while index < len(args):
        arg = args[index]
        spread.append(arg)
        index += 1
        if arg == "--":
            return spread + list(args[index:])
        if arg == "--bus-kwargs" and index < len(args):
            spread.append(args[index])
            index += 1
        elif not arg.startswith("--bus-kwargs="):
            continue
        while index < len(args) and _BUS_KWARG.fullmatch(args[index]):
            spread += ["--bus-kwargs", args[index]]
            index += 1
    return spread


#: the bus options' names as a command line spells them -> their long names
BUS_OPTION_NAMES = {"-i": "--interface", "--interface": "--interface", "-c": "--channel",
                    "--channel": "--channel", "-b": "--bitrate", "--bitrate": "--bitrate",
                    "--bus-kwargs": "--bus-kwargs"}


def takes_bus_options(command: click.Command) -> bool:
    """Whether ``command`` (or, for a group, its own options) takes the bus options."""
    return any(param.name == "interface" for param in command.params)


def given_bus_options(ctx: click.Context) -> list[str]:
    """The bus options given so far on this command line (``-i/--interface``, ...)."""
    given = _settings(ctx)
    names = [f"--{name}" for name in ("interface", "channel", "bitrate") if name in given]
    return names + (["--bus-kwargs"] if given["kwargs"] else [])


def bus_option_in(args: Sequence[str]) -> str | None:
    """The long name of the first of ``args`` (up to ``--``) that is a bus option (``-i``,
    ``-iX``, ``--interface=X``: ``--interface``), or None."""
    for arg in args:
        if arg == "--":
            return None
        name = arg.partition("=")[0] if arg.startswith("--") else arg[:2]
        if name in BUS_OPTION_NAMES:
            return BUS_OPTION_NAMES[name]
    return None


def bus_options(function: F) -> F:
    """The bus options, recorded for :func:`cli_bus` (see the module docstring)."""
    options = [
        click.option("-i", "--interface", default=None, expose_value=False, callback=_remember,
                     help="python-can interface (socketcan, pcan, kvaser, slcan, udp_multicast,"
                          " virtual, ...). Default: python-can's configuration, else "
                          f"{DEFAULT_INTERFACE} {DEFAULT_GROUP}:{DEFAULT_PORT}, hop limit 0 "
                          "(this machine only)."),
        click.option("-c", "--channel", default=None, expose_value=False, callback=_remember,
                     help="Channel, e.g. can0, PCAN_USBBUS1 or a multicast group."),
        click.option("-b", "--bitrate", type=Whole(1, MAX_BITRATE, "bit/s"), default=None,
                     expose_value=False,
                     callback=_remember, help="Bit rate in bit/s (python-can config if unset)."),
        click.option("--bus-kwargs", multiple=True, metavar="NAME=VALUE...", expose_value=False,
                     callback=_remember,
                     help="More arguments for the bus, as python-can's tools take them, e.g. "
                          "--bus-kwargs port=43114 hop_limit=0."),
    ]
    for option in reversed(options):
        function = option(function)
    return function


def _configured(settings: dict[str, Any]) -> bool:
    """Whether python-can's configuration (file or environment) names an interface."""
    import can  # noqa: PLC0415 (start-up: only where a bus is named)

    try:
        can.util.load_config(config={k: v for k, v in settings.items() if k != "kwargs"})
    except can.CanInterfaceNotImplementedError:
        return False
    return True


def bus_settings(ctx: click.Context | None = None) -> dict[str, Any]:
    """The keyword arguments of the bus this command line names (defaults filled in)."""
    settings = dict(_settings(ctx or click.get_current_context()))
    kwargs = dict(settings.pop("kwargs"))
    chosen: dict[str, Any] = {**kwargs, **settings}
    if "interface" not in chosen and not _configured(chosen):
        chosen.setdefault("channel", DEFAULT_GROUP)
        chosen.setdefault("port", DEFAULT_PORT)
        chosen.setdefault("hop_limit", DEFAULT_HOP_LIMIT)
        chosen["interface"] = DEFAULT_INTERFACE
    return chosen


def describe_bus(settings: dict[str, Any]) -> str:
    """The bus in words, for banners: ``udp_multicast 239.74.163.2:43113 (hop limit 0, this
    machine only)``."""
    interface = settings.get("interface") or "python-can's configured interface"
    if interface == "udp_multicast":
        hops = settings.get("hop_limit", 1)
        reach = "this machine only" if hops == 0 else "sent on the network"
        return (f"udp_multicast {settings.get('channel', '(python-can default group)')}:"
                f"{settings.get('port', DEFAULT_PORT)} (hop limit {hops}, {reach})")
    channel = settings.get("channel")
    return f"{interface} {channel}" if channel is not None else str(interface)


def cli_bus() -> can.BusABC:
    """The bus the options name; a bus that cannot be opened is one clear line, not a trace.
    python-can's backends fail in many ways (a missing vendor library, a missing channel), so
    every exception is caught here and named."""
    settings = bus_settings()
    config = dict(settings)
    interface, channel, bitrate = (config.pop(key, None)
                                   for key in ("interface", "channel", "bitrate"))
    try:
        from blinkcan.runtime import open_bus  # noqa: PLC0415 (start-up: issue 22)

        return open_bus(interface, channel, bitrate, **config)
    except TypeError as error:
        missing = re.search(r"missing \d+ required (?:positional )?arguments?: (.*)", str(error))
        if missing is not None:
            raise click.ClickException(
                f"cannot open the bus {describe_bus(settings)}: it needs {missing[1]} "
                "(-c CHANNEL, or --bus-kwargs NAME=VALUE)") from None
        raise click.ClickException(f"cannot open the bus {describe_bus(settings)}: "
                                   f"{error}") from None
    except Exception as error:  # see the docstring
        raise click.ClickException(f"cannot open the bus {describe_bus(settings)}: "
                                   f"{error or type(error).__name__}") from None


def parse_int(text: str) -> int:
    """A number as engineers write it: 21, 0x15 or 15h."""
    cleaned = text.strip().lower()
    try:
        if cleaned.endswith("h"):
            return int(cleaned[:-1], 16)
        return int(cleaned, 0)
    except ValueError:
        raise click.BadParameter(f"{text!r} is not a number (21, 0x15 or 15h)") from None


def parse_node_id(text: str) -> int:
    """A node id 1..127 as engineers write it (21, 0x15 or 15h); BadParameter otherwise."""
    try:
        return check_node_id(parse_int(text))
    except click.BadParameter:
        raise click.BadParameter(f"{text!r} is not a node id: 01h..7Fh (21, 0x15 or "
                                 "15h)") from None
    except ValueError as error:
        raise click.BadParameter(str(error)) from None


class NodeId(click.ParamType):  # type: ignore[type-arg]
    """A click type for node ids: 21, 0x15 or 15h, 1..127."""

    name = "NODE"

    def convert(self, value: Any, param: click.Parameter | None,
                ctx: click.Context | None) -> int:
        try:
            return parse_node_id(str(value))
        except click.BadParameter as error:
            self.fail(error.message, param, ctx)


NODE_ID = NodeId()
