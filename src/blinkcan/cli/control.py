"""``blinkcan keypad ...`` and ``blinkcan keybox ...``: one-shot control and configuration on
top of the host drivers. Every action prints what it did; changing a node id or bit rate and
restoring factory defaults ask for confirmation first (``--yes`` does not ask).

Every command, PDO-only ones included (``keypad led``), first confirms which device answers at
the node id (the drivers' identity check): nothing answering, another kind of device, or more
than one device answering ("two devices answer at node 15h") is one line and a non-zero exit,
and the bus sees no command.

Arguments come first (``cli/ranges.py``): checked against the models that may answer before the
bus is opened (``--model`` names one; else every registered model of the kind), then against
the model found at the node id before any command. A question ("Go on?") comes after the device
was found, never before."""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator, Sequence
from contextlib import contextmanager
from typing import Any

import can
import click
from click.core import ParameterSource

from blinkcan.cli.answers import confirm
from blinkcan.cli.bus_options import NODE_ID, bus_options, cli_bus, parse_int
from blinkcan.cli.ranges import (
    Check,
    Spans,
    candidates,
    describe,
    entry_spans,
    merged,
    spans_of,
    whose,
    within,
)
from blinkcan.cli.whole import NegativeArguments
from blinkcan.devices.colours import BacklightColour, led_colour
from blinkcan.devices.keypad_j1939 import BITRATES as J1939_BITRATES
from blinkcan.devices.keypad_j1939 import DEFAULT_ADDRESS, colour_code
from blinkcan.devices.keypad_j1939 import TIME_UNIT_S as J1939_TIME_UNIT_S
from blinkcan.devices.keypad_j1939 import command as j1939_command
from blinkcan.devices.model import DeviceDescription, Face, Model
from blinkcan.devices.objects import ObjectEntry
from blinkcan.devices.registry import identify, model, models
from blinkcan.host import HostBus, IdentityError, Keybox, Keypad, SdoError, SharedNodeIdError
from blinkcan.host.device import NoDeviceError, check_one_device
from blinkcan.host.j1939_keypad import J1939Identity
from blinkcan.host.registry import driver_class
from blinkcan.protocol.j1939 import ADDRESS_MAX
from blinkcan.protocol.sdo_client import SdoProtocolError, SdoTimeoutError

#: what the group passes to its commands: the device kind and its node id
Target = tuple[str, int]
#: what a whole number argument may be for the models that may answer: spans, or said in words
Valid = Callable[[Sequence[DeviceDescription]], "Spans | str"]
#: ``blinkcan keypad --protocol j1939 --address 0x21``: kept in the context's meta
_J1939_ADDRESS = "blinkcan.j1939_address"
#: ``blinkcan keypad --model pkp-3500-mt``: kept in the context's meta
_MODEL = "blinkcan.model"


#: ``--node-id`` as given on the command line (not its default): over J1939, the address
_NODE_ID_GIVEN = "blinkcan.node_id_given"
#: ``--address`` was given (not only ``--protocol j1939``, whose address is 21h)
_ADDRESS_GIVEN = "blinkcan.address_given"


def _j1939_address() -> int | None:
    """The keypad's J1939 address when ``--protocol j1939`` (or ``--address``) was given, else
    None: ``--address``, else a ``--node-id`` given (a keypad in J1939 mode is reached at its
    source address, as ``emulate keypad:0x30 --protocol j1939`` claims 30h), else 21h. Beside
    ``--address``, ``--node-id`` is the keypad's CANopen node id (the driver's, for a switch
    back)."""
    context = click.get_current_context(silent=True)
    if context is None:
        return None
    address: int | None = context.meta.get(_J1939_ADDRESS)
    given: int | None = context.meta.get(_NODE_ID_GIVEN)
    if address is None or given is None or context.meta.get(_ADDRESS_GIVEN):
        return address  # with --address, --node-id is its CANopen node id (a switch back)
    return given


def _chosen_model() -> str | None:
    """The model named with ``--model``, else None (found from the device)."""
    context = click.get_current_context(silent=True)
    return None if context is None else context.meta.get(_MODEL)


def _model_at(bus: Any, node_id: int, kind: str) -> Model:
    """The registered model of ``kind`` whose model id (100Bh) the device at ``node_id``
    reports; the kind's first model when it reports none of them (its driver's identity check
    then says what answered instead)."""
    first = model(kind)
    host = HostBus.attach(bus)
    try:
        raw = host.sdo(node_id, 0.5, 1).upload(0x100B, 0)
    except SdoTimeoutError as error:
        raise NoDeviceError(f"no device answers at node {node_id:02X}h ({error})") from None
    except SdoError:
        return first
    finally:
        host.release()
    found = identify(model_id=raw.decode("ascii", "replace"))
    if found is None:
        return first
    answering = model(found.model)
    base = driver_class(first.name)
    return answering if issubclass(driver_class(answering.name), base) else first


def _candidates(kind: str) -> tuple[DeviceDescription, ...]:
    """The descriptions that may answer this command (J1939: the models that have the mode)."""
    return candidates(kind, _chosen_model(), "j1939" if _j1939_address() is not None else None)


def _arguments(kind: str, check: Check) -> None:
    """``check`` against every model that may answer, before the bus: a usage error naming
    the valid values. A command with no J1939 message is refused first, over J1939."""
    if _j1939_address() is not None:
        _refuse_unless_j1939_has(click.get_current_context().info_name or "")
    descriptions = _candidates(kind)
    try:
        check(descriptions)
    except ValueError as error:
        raise click.UsageError(f"{error} ({whose(descriptions)})") from None


class ModelNumber(click.ParamType):  # type: ignore[type-arg]
    """A whole number argument of a keypad/keybox command (12, 0x0C or 0Ch): text that is none
    is a usage error naming the argument and what the models that may answer take (``valid``
    of their descriptions); the range itself is checked with the command's other arguments."""

    name = "integer"

    def __init__(self, what: str, valid: Valid) -> None:
        self.what = what
        self.valid = valid

    def convert(self, value: Any, param: click.Parameter | None,
                ctx: click.Context | None) -> int:
        if isinstance(value, int) and not isinstance(value, bool):
            return value
        try:
            return parse_int(str(value))
        except click.BadParameter:
            self.fail(_not_whole(self.what, str(value), self.valid), param, ctx)


def _not_whole(what: str, text: str, valid: Valid) -> str:
    """"PWM duty 'abc' is not a whole number: 0..10 (the Keybox)", for the models that may
    answer this command (its group's kind, ``--model``)."""
    context = click.get_current_context(silent=True)
    kind = context.obj[0] if context is not None and isinstance(context.obj, tuple) else None
    if kind is None:
        return f"{what} {text!r} is not a whole number"
    descriptions = _candidates(kind)
    shown = valid(descriptions)
    return (f"{what} {text!r} is not a whole number: "
            f"{shown if isinstance(shown, str) else describe(shown)} ({whose(descriptions)})")


def _whole(what: str, text: str, valid: Valid, hint: str) -> int:
    """``text`` (part of a list argument, e.g. PWM's PINS) as a whole number; else a usage
    error naming the argument ``hint`` and what the models take."""
    try:
        return parse_int(text)
    except click.BadParameter:
        raise click.BadParameter(_not_whole(what, text, valid), param_hint=hint) from None


def _pins(descriptions: Sequence[DeviceDescription]) -> Spans:
    return merged(spans_of(d.face.pin_numbers) for d in descriptions)


def _pwm_pins(descriptions: Sequence[DeviceDescription]) -> Spans:
    return merged(spans_of(d.face.pwm_pins) for d in descriptions)


def _led_keys(descriptions: Sequence[DeviceDescription]) -> Spans:
    return merged(spans_of(d.face.led_keys) for d in descriptions)


def _encoders(descriptions: Sequence[DeviceDescription]) -> Spans:
    return merged(spans_of(e.number for e in d.face.encoders) for d in descriptions)


def _entries(suffix: str) -> Valid:
    """What the object ``suffix`` names takes; ``encoder_{n}_...`` over every encoder."""
    def valid(descriptions: Sequence[DeviceDescription]) -> Spans | str:
        names = sorted({suffix.format(n=e.number) for d in descriptions
                        for e in d.face.encoders} if "{n}" in suffix else {suffix})
        spans = merged(entry_spans(descriptions, name) for name in names)
        entries = [d.table[name] for d in descriptions for name in names if name in d.table]
        return spans or (entries[0].describe_valid() if entries else "none")

    return valid


def _bitrates(descriptions: Sequence[DeviceDescription]) -> str:
    rates = sorted({rate for d in descriptions for rate in d.bitrates.values()})
    return f"one of {', '.join(map(str, rates))} bit/s"


@contextmanager
def _device(target: Target, start: bool = False, check: Check | None = None
            ) -> Iterator[Any]:
    """The driver of the device at the target's node id: the model its 100Bh names (or
    ``--model``), driven by that model's driver class from the registry. ``check`` runs
    first against every model of the kind that may answer (before the bus opens), then
    against that model before anything but the identity reads is sent, then ``start`` starts
    the device (NMT): a bad argument never reaches it."""
    kind, node_id = target
    if check is not None:
        _arguments(kind, check)
    address = _j1939_address()
    if address is not None:
        _refuse_unless_j1939_has(click.get_current_context().info_name or "")
    bus = cli_bus()
    try:
        try:
            if address is not None:  # J1939 mode answers no SDO: --model, else the kind's first
                device = driver_class(kind)(bus, node_id, protocol="j1939", address=address,
                                            model=_chosen_model())
            else:
                chosen = _chosen_model()
                found = model(chosen) if chosen else _model_at(bus, node_id, kind)
                device = driver_class(found.name)(bus, node_id, start=False)
        except (IdentityError, SdoError, ValueError) as error:
            raise click.ClickException(_explained(error, bus, node_id)) from None
        try:
            if check is not None:
                _check_found(check, device.description, node_id)
            if start and address is None:  # J1939 has no NMT
                device.start()
            yield device
        except (IdentityError, SdoError, TimeoutError, ValueError) as error:
            raise click.ClickException(_explained(error, bus, node_id)) from None
        finally:
            device.close()
    finally:
        bus.shutdown()


#: the commands a keypad in J1939 mode answers from the command line, as said when another is
#: asked (spec/pkp-2600-si-j1939.md: no SDO, no 1011h restore, no NMT)
J1939_COMMANDS = {
    "info": "info", "led": "led", "backlight": "backlight", "brightness": "brightness",
    "heartbeat": "heartbeat", "set-node-id": "set-node-id (its source address, §16)",
    "set-baud": "set-baud (500000 or 250000 bit/s, §15)",
}


def _refuse_unless_j1939_has(command: str) -> None:
    """A command a keypad in J1939 mode has no J1939 message for, or a ``--model`` without a
    J1939 mode, is refused before the bus is opened, naming what works over J1939."""
    chosen = _chosen_model()
    if chosen is not None and not candidates("keypad", chosen, "j1939"):
        having = ", ".join(dict.fromkeys(d.title for d in candidates("keypad", None, "j1939")))
        raise click.UsageError(f"the {model(chosen).description().title} has no J1939 mode "
                               f"(J1939: {having})")
    if command not in J1939_COMMANDS:
        raise click.UsageError(f"{command} has no J1939 command on this keypad; over J1939: "
                               f"{', '.join(J1939_COMMANDS.values())}")


def _check_found(check: Check, description: DeviceDescription, node_id: int) -> None:
    try:
        check([description])
    except ValueError as error:
        raise click.ClickException(f"{error} ({whose([description])} at node "
                                   f"{node_id:02X}h)") from None


def _explained(error: Exception, bus: can.BusABC, node_id: int) -> str:
    """The error's message; for a reply that did not fit its request, what may be behind it:
    more than one device answering at the node id (then that is the message)."""
    if isinstance(error, SdoProtocolError):
        host = HostBus.attach(bus)
        try:
            check_one_device(host.sdo(node_id))
        except SharedNodeIdError as shared:
            return str(shared)
        except SdoError:
            pass  # the diagnosis itself failed: the first error stands
        finally:
            host.release()
    return str(error)


def _subject(target: Target) -> str:
    """The device as the command line names it: ``keybox 0Ch``, ``keypad 21h (J1939)``."""
    kind, node_id = target
    address = _j1939_address()
    if address is not None:
        return f"{kind} {address:02X}h (J1939)"
    return f"{kind} {node_id:02X}h"


def _done(target: Target, what: str) -> None:
    """One line saying what an action did, e.g. ``keybox 0Ch: output 4 HIGH``."""
    click.echo(f"{_subject(target)}: {what}")


def _info(device: Any) -> None:
    identity = device.identity()
    if isinstance(identity, J1939Identity):  # §11, §18, §20: what J1939 tells
        click.echo(f"{'address':<17} {identity.address:02X}h (J1939)")
        for name in ("model", "software_version", "name", "claim"):
            value = getattr(identity, name)
            click.echo(f"{name:<17} {'not heard' if value is None else value}")
        heartbeat = identity.heartbeat or \
            f"not heard within {identity.heartbeat_wait * 1000:.0f} ms (off, or slower)"
        click.echo(f"{'heartbeat':<17} {heartbeat}")
        return
    for name in ("node_id", "model", "model_id", "device_name", "hardware_version",
                 "software_version", "serial_number"):
        value = getattr(identity, name)
        if value is not None:
            click.echo(f"{name:<17} {value:02X}h" if name == "node_id" else f"{name:<17} {value}")
    click.echo(f"{'vendor_id':<17} {identity.vendor_id:08X}h")


def _set_node_id(ctx: click.Context, param: click.Parameter, value: int | None) -> None:
    if value is not None:
        ctx.obj = (ctx.obj[0], value)
        ctx.meta[_NODE_ID_GIVEN] = value


#: ``--node-id`` after the command too (``blinkcan keypad info --node-id 0x16``)
node_id_option = click.option("--node-id", type=NODE_ID, default=None, expose_value=False,
                              callback=_set_node_id, help="The device's node id.")


def _models_of(kind: str) -> list[Model]:
    return [found for found in models() if found.kind == kind]


def _spans(numbers: Iterable[int]) -> str:
    """[1, 2, 3, 5] -> "1-3, 5"."""
    spans: list[list[int]] = []
    for number in sorted(numbers):
        if spans and number == spans[-1][-1] + 1:
            spans[-1].append(number)
        else:
            spans.append([number])
    return ", ".join(f"{s[0]}-{s[-1]}" if len(s) > 1 else f"{s[0]}" for s in spans)


def _per_model(kind: str, numbers: Callable[[Face], Iterable[int]]) -> str:
    """What each model of ``kind`` has, from its face: "1-12 (PKP-2600-SI keypad), ..."."""
    return ", ".join(f"{_spans(numbers(found.description().face))} "
                     f"({found.description().title})" for found in _models_of(kind)
                     if tuple(numbers(found.description().face)))


def _set_model(ctx: click.Context, param: click.Parameter, value: str | None) -> None:
    if value is not None:
        ctx.meta[_MODEL] = value


def _group(kind: str) -> click.Group:
    """The command group of one kind of device, its models and their names from the
    registry."""
    default = model(kind).default_node_id
    kinds = _models_of(kind)
    titles = ", ".join(found.description().title for found in kinds)
    names = [name for found in kinds for name in found.names]
    j1939 = any("j1939" in found.description(generation).features
                for found in kinds for generation in found.generations)

    @click.group(kind, help=f"One-shot control of a {kind}. Models: {titles}; which one is "
                            "read from the device (100Bh) unless --model names it.")
    @click.option("--node-id", type=NODE_ID, default=default,
                  help=f"The {kind}'s node id (default {default:02X}h)" + (
                      "; over J1939 with no --address, its source address." if j1939 else "."))
    @click.option("--model", type=click.Choice(names, case_sensitive=False), default=None,
                  expose_value=False, callback=_set_model,
                  help="Drive the device as this model (default: the one it says it is).")
    @bus_options
    @click.pass_context
    def group(ctx: click.Context, node_id: int) -> None:
        ctx.obj = (kind, node_id)
        if ctx.get_parameter_source("node_id") is not ParameterSource.DEFAULT:
            ctx.meta[_NODE_ID_GIVEN] = node_id

    group.command_class = NegativeArguments  # ``keybox on -1``: a pin, refused by its range
    return group


keypad = _group("keypad")


class J1939Address(click.ParamType):  # type: ignore[type-arg]
    """A J1939 source address: 0x21, 33 or 21h, 01h..FDh."""

    name = "ADDRESS"

    def convert(self, value: Any, param: click.Parameter | None,
                ctx: click.Context | None) -> int:
        try:
            address = parse_int(str(value))
        except click.BadParameter:
            self.fail(f"{value!r} is not a J1939 keypad address: 01h..{ADDRESS_MAX:02X}h (33, "
                      "0x21 or 21h)", param, ctx)
        if not 0x01 <= address <= ADDRESS_MAX:
            self.fail(f"a J1939 keypad address is 01h..{ADDRESS_MAX:02X}h, not {value}", param,
                      ctx)
        return address


def _set_protocol(ctx: click.Context, param: click.Parameter, value: str | None) -> None:
    if value == "j1939":
        ctx.meta.setdefault(_J1939_ADDRESS, DEFAULT_ADDRESS)
    elif value == "canopen":
        ctx.meta.pop(_J1939_ADDRESS, None)


def _set_address(ctx: click.Context, param: click.Parameter, value: int | None) -> None:
    if value is not None:
        ctx.meta[_J1939_ADDRESS] = value
        ctx.meta[_ADDRESS_GIVEN] = True


# a keypad in J1939 mode (spec/pkp-2600-si-j1939.md): led, backlight and brightness go as J1939
# commands to its source address (--address implies --protocol j1939)
keypad.params += [
    click.Option(["--protocol"], type=click.Choice(["canopen", "j1939"]), default=None,
                 expose_value=False, is_eager=True, callback=_set_protocol,
                 help="The keypad's protocol (default canopen)."),
    click.Option(["--address"], type=J1939Address(), default=None,
                 expose_value=False, callback=_set_address,
                 help=f"J1939 source address of the keypad (default {DEFAULT_ADDRESS:02X}h)."),
]
keybox = _group("keybox")


for group in (keypad, keybox):
    @group.command("info")
    @bus_options
    @node_id_option
    @click.pass_obj
    def info(target: Target) -> None:
        """Identity: name, model, versions (un-reversed), serial, vendor."""
        with _device(target) as device:
            _info(device)

    @group.command("heartbeat")
    @click.argument("milliseconds", type=ModelNumber("heartbeat period in ms",
                                                     _entries("producer_heartbeat_time")))
    @bus_options
    @node_id_option
    @click.pass_obj
    def heartbeat(target: Target, milliseconds: int) -> None:
        """Producer heartbeat period in ms (0 = off)."""

        def check(descriptions: Sequence[DeviceDescription]) -> None:
            if _j1939_address() is not None:  # §18: on, and a period of 05h-FEh x 10 ms
                _check_j1939_heartbeat(milliseconds)
                return
            within("heartbeat period in ms", milliseconds,
                   entry_spans(descriptions, "producer_heartbeat_time"))

        with _device(target, check=check) as device:
            device.set_heartbeat(milliseconds / 1000)
        _done(target, f"heartbeat every {milliseconds} ms" if milliseconds else "heartbeat off")

    @group.command("set-node-id")
    @click.argument("new_id_text", metavar="NEW_ID")
    @click.option("--yes", is_flag=True, help="Do not ask.")
    @bus_options
    @node_id_option
    @click.pass_obj
    def set_node_id(target: Target, new_id_text: str, yes: bool) -> None:
        """Store a new node id (applies at the next reset; generation 2 keypads: at once).
        Over J1939 the keypad's source address (01h..FDh, at once). Asks once the device was
        found and the new id is free."""
        argument = next(p for p in click.get_current_context().command.params
                        if p.name == "new_id_text")  # NEW_ID, named in its errors
        if _j1939_address() is not None:
            _set_j1939_address(target, J1939Address().convert(new_id_text, argument, None), yes)
            return
        new_id = NODE_ID.convert(new_id_text, argument, None)

        def check(descriptions: Sequence[DeviceDescription]) -> None:
            within("node id", new_id, entry_spans(descriptions, "node_id"))

        with _device(target, check=check) as device:
            if new_id != target[1]:
                device.check_free(new_id)  # before asking: a taken id is refused anyway
            confirm(f"The {target[0]} will move to node {new_id:02X}h", yes)
            device.set_node_id(new_id, confirm=True)
        _done(target, f"node id {new_id:02X}h stored")

    @group.command("set-baud")
    @click.argument("bit_rate", metavar="BITRATE", type=ModelNumber("bit rate", _bitrates))
    @click.option("--yes", is_flag=True, help="Do not ask.")
    @bus_options
    @node_id_option
    @click.pass_obj
    def set_baud(target: Target, bit_rate: int, yes: bool) -> None:
        """Store a bit rate in bit/s, with this model's own code (applies at the next reset).
        Asks once the device was found."""

        def check(descriptions: Sequence[DeviceDescription]) -> None:
            rates = sorted({rate for d in descriptions for rate in d.bitrates.values()})
            if _j1939_address() is not None:  # §15: the J1939 mode's own two codes
                rates = sorted(J1939_BITRATES.values())
            if bit_rate not in rates:
                raise ValueError(f"bit rate {bit_rate} bit/s is not one of "
                                 f"{', '.join(map(str, rates))}")

        with _device(target, check=check) as device:
            confirm(f"The {target[0]} will leave this bus for {bit_rate} bit/s at its next "
                     "reset", yes)
            device.set_bitrate(bit_rate, confirm=True)
        after = "reset" if _j1939_address() is None else "power-on"  # J-3
        _done(target, f"bit rate {bit_rate} bit/s stored, in use after the next {after}")

    @group.command("restore-defaults")
    @click.option("--yes", is_flag=True, help="Do not ask.")
    @bus_options
    @node_id_option
    @click.pass_obj
    def restore_defaults(target: Target, yes: bool) -> None:
        """Every stored setting back to factory values (1011h), applied at the next reset."""
        with _device(target) as device:
            if "restore_all_parameters" not in device.description.table:  # before asking
                edition = device.description.edition or "this firmware"
                raise click.ClickException(f"this {device.description.title} ({edition}) "
                                           "cannot restore defaults (it has no 1011h)")
            confirm(f"Every stored setting of the {target[0]} (node id, bit rate, "
                     "heartbeat...) goes back to its factory value at the next reset", yes)
            device.restore_factory_defaults(confirm=True)
        _done(target, "factory defaults restored; they apply at the next reset")

    @group.command("read")
    @click.argument("name")
    @bus_options
    @node_id_option
    @click.pass_obj
    def read(target: Target, name: str) -> None:
        """Read one object of the model's dictionary by NAME (as ``export eds`` lists them,
        e.g. encoder_1_top)."""
        with _device(target, check=_object_check(name)) as device:
            entry = _entry(device, name)
            value = device.read(name)
        shown = f"{value} ({value:#x})" if isinstance(value, int) else value
        click.echo(f"{name} ({entry.index:04X}h/{entry.subindex:02X}): {shown}")

    @group.command("write")
    @click.argument("name")
    @click.argument("value")
    @bus_options
    @node_id_option
    @click.pass_obj
    def write(target: Target, name: str, value: str) -> None:
        """Write one object of the model's dictionary by NAME; VALUE is checked against the
        model's valid values first."""
        with _device(target, check=_object_check(name, value)) as device:
            entry = _entry(device, name)
            number: int | str = value if entry.data_type.is_string else parse_int(value)
            device.write(name, number)
        _done(target, f"{name} ({entry.index:04X}h/{entry.subindex:02X}) = {value}")


def _check_j1939_heartbeat(milliseconds: int) -> None:
    """A J1939 heartbeat period the keypad can take (§18: 75h, period 05h-FEh x 10 ms; 0 is
    off): ValueError naming the range, or the step a period between two steps lacks."""
    period = next(f for f in j1939_command("heartbeat").fields if f.name == "period")
    step = round(J1939_TIME_UNIT_S * 1000)
    within("heartbeat period in ms", milliseconds,
           ((0, 0), (period.valid.low * step, period.valid.high * step)))
    if milliseconds % step:
        raise ValueError(f"heartbeat period {milliseconds} ms is not a multiple of {step} ms "
                         "(J1939 §18)")


def _set_j1939_address(target: Target, address: int, yes: bool) -> None:
    """set-node-id over J1939: the source address (§16, 70h), in use at once (J-3)."""
    with _device(target) as device:
        confirm(f"The {target[0]} will move to J1939 address {address:02X}h now", yes)
        device.set_node_id(address, confirm=True)
    _done(target, f"source address {address:02X}h stored and in use")


def _blink_words(colour: str, blink: str | None) -> str:
    if blink is None:
        return colour
    if colour in (blink, "off"):
        return f"blinking {blink}"
    return f"{colour} alternating with {blink}"


@keypad.command("led", epilog=f"Keys with an LED: {_per_model('keypad', lambda f: f.led_keys)}.")
@click.argument("key", type=ModelNumber("key", _led_keys))
@click.argument("colour")
@click.option("--blink", is_flag=False, flag_value="", default=None, metavar="[COLOUR]",
              help="Blink: alone, COLOUR blinks on and off; with another colour, the LED "
                   "alternates between the two.")
@bus_options
@node_id_option
@click.pass_obj
def led(target: Target, key: int, colour: str, blink: str | None) -> None:
    """Light KEY in COLOUR (off, red, green, blue, yellow/amber, cyan, magenta,
    white; over J1939 also amber/orange and yellow/green, each its own colour). Starts the
    keypad; the other keys keep what they show (read from the keypad first; over J1939 only
    KEY's command is sent).

    \b
    blinkcan keypad led 3 red
    blinkcan keypad led 3 blue --blink          (blue, blinking)
    blinkcan keypad led 3 red --blink green     (red and green alternating)
    """
    blink = colour if blink == "" else blink

    def check(descriptions: Sequence[DeviceDescription]) -> None:
        within("key", key, _led_keys(descriptions))
        # J1939 mode has colour codes of its own (§7a: amber, yellow/green)
        known = colour_code if _j1939_address() is not None else led_colour
        for name in (colour, blink):
            if name is not None:
                known(name)

    with _device(target, start=True, check=check) as device:
        assert isinstance(device, Keypad)
        if device.j1939 is None:  # CANopen: the LED PDO carries every key, so read them first
            device.read_leds()
        device.set_led(key, colour, blink=blink)
    _done(target, f"key {key} {_blink_words(colour, blink)}")


@keypad.command("backlight")
@click.option("--colour", default=None, help="Backlight colour (red ... yellow/green).")
@click.option("--level", type=ModelNumber("backlight level", _entries("backlight_brightness")),
              default=None, help="0-63 (0 = off).")
@bus_options
@node_id_option
@click.pass_obj
def backlight(target: Target, colour: str | None, level: int | None) -> None:
    """Backlight colour and level."""
    if colour is None and level is None:
        raise click.UsageError("name a --colour, a --level or both")

    def check(descriptions: Sequence[DeviceDescription]) -> None:
        if colour is not None:
            BacklightColour.from_name(colour)
        if level is not None:
            within("backlight level", level, entry_spans(descriptions, "backlight_brightness"))

    with _device(target, start=True, check=check) as device:
        assert isinstance(device, Keypad)
        device.set_backlight(colour, level)
    parts = ([f"colour {colour}"] if colour is not None else []) + (
        [f"level {level}"] if level is not None else [])
    _done(target, f"backlight {', '.join(parts)}")


@keypad.command("brightness")
@click.argument("level", type=ModelNumber("brightness", _entries("indicator_brightness")))
@bus_options
@node_id_option
@click.pass_obj
def brightness(target: Target, level: int) -> None:
    """Indicator LED brightness 0-63."""

    def check(descriptions: Sequence[DeviceDescription]) -> None:
        within("brightness", level, entry_spans(descriptions, "indicator_brightness"))

    with _device(target, start=True, check=check) as device:
        assert isinstance(device, Keypad)
        device.set_brightness(level)
    _done(target, f"indicator brightness {level}")


def _read_back(target: Target, device: Keybox, command: Callable[[], None],
               pins: Sequence[int], wanted: str, asked: str) -> str | None:
    """Run an output ``command``, then read ``pins`` back (2001h per pin, KBX §19) and
    compare them with the state ``wanted`` ("high", "off"): what the Keybox shows is what the
    command line says. An output switched HIGH onto a blown fuse or a short goes FAULT (KBX
    §7), and OFF leaves a FAULT latched (errata K12): an error naming it, not "HIGH"/"OFF".
    An acknowledge lost on the bus (``SdoTimeoutError.uncertain``) leaves the command applied
    or not: the read says which. Returns a note to print when the acknowledge was lost and
    the read shows the command applied; raises ClickException otherwise."""
    lost: SdoTimeoutError | None = None
    try:
        command()
    except SdoTimeoutError as error:
        if not error.uncertain:
            raise
        lost = error
    try:
        shown = {pin: device.state(pin) for pin in pins}
    except SdoError:
        if lost is not None:
            raise lost from None  # neither the acknowledge nor the read: as it was
        raise
    wrong = {pin: state for pin, state in shown.items() if state != wanted}
    if not wrong:
        return None if lost is None else (
            "the Keybox's acknowledge was lost on the bus; the outputs were read back: "
            "the command is applied")
    read = ", ".join(f"output {pin} is {state.upper()}" for pin, state in sorted(wrong.items()))
    if lost is not None:
        raise click.ClickException(f"{lost}; read back: {read}")
    faulted = sorted(pin for pin, state in wrong.items() if state == "fault")
    if faulted:
        pins_text = ",".join(str(pin) for pin in faulted)
        outputs = " and ".join(str(pin) for pin in faulted)
        how = ("went FAULT when switched " + asked if wanted == "high" else
               f"stays FAULT: {asked} does not clear a fault (KBX §7)")
        raise click.ClickException(
            f"{_subject(target)}: output {outputs} {how}; a blown fuse or a short on it: "
            f"`blinkcan keybox reset {pins_text}` once it is mended")
    raise click.ClickException(f"{_subject(target)}: {asked} acknowledged, but read back: "
                               f"{read}")


def _pin_command(name: str, action: str, doc: str, done: str, wanted: str, asked: str
                 ) -> None:
    @keybox.command(name, help=doc)
    @click.argument("pin", type=ModelNumber("pin", _pins))
    @bus_options
    @node_id_option
    @click.pass_obj
    def command(target: Target, pin: int) -> None:
        def check(descriptions: Sequence[DeviceDescription]) -> None:
            within("pin", pin, _pins(descriptions))

        with _device(target, check=check) as device:
            note = _read_back(target, device, lambda: getattr(device, action)(pin), [pin],
                              wanted, asked)
        _done(target, done.format(pin=pin))
        if note is not None:
            click.echo(note, err=True)


_pin_command("on", "on", f"Output PIN HIGH; pins {_per_model('keybox', lambda f: f.pin_numbers)}.",
             "output {pin} HIGH", "high", "HIGH")
_pin_command("off", "off", "Output PIN OFF.", "output {pin} OFF", "off", "OFF")
_pin_command("reset", "reset", "RESET output PIN out of FAULT.", "output {pin} RESET (now OFF)",
             "off", "RESET")


@keybox.command("pwm", epilog=f"PWM pins: {_per_model('keybox', lambda f: f.pwm_pins)}.")
@click.argument("pins")
@click.argument("duty")
@bus_options
@node_id_option
@click.pass_obj
def pwm(target: Target, pins: str, duty: str) -> None:
    """PWM on PINS (one or several, comma-separated) at DUTY 0-10 tenths, or 0%-100% in
    steps of 10.
    Pins not named leave PWM.

    \b
    blinkcan keybox pwm 12 5
    blinkcan keybox pwm 12,13 30%
    """
    chosen = sorted({_whole("PWM pin", pin, _pwm_pins, "PINS") for pin in pins.split(",")
                     if pin.strip()})  # a pin named twice is one pin
    levels = max((d.face.pwm_duty_max for d in _candidates(target[0])), default=0)
    step = 100 // levels if levels else 100  # KBX §22: 0Ah = 100 %, steps of 10 %
    percent = duty.strip().endswith("%")

    def duties(descriptions: Sequence[DeviceDescription]) -> Spans:
        top = max((d.face.pwm_duty_max for d in descriptions), default=0)
        return ((0, top * step),) if percent else ((0, top),)

    level = _whole("PWM duty in %" if percent else "PWM duty",
                   duty.strip()[:-1] if percent else duty, duties, "DUTY")
    if percent and level % step:
        raise click.BadParameter(f"{duty} is not a step of {step} %", param_hint="DUTY")
    tenths = level // step if percent else level

    def check(descriptions: Sequence[DeviceDescription]) -> None:
        allowed = _pwm_pins(descriptions)
        for pin in chosen:
            within("PWM pin", pin, allowed)
        within("PWM duty in %" if percent else "PWM duty", level, duties(descriptions))

    with _device(target, check=check) as device:
        assert isinstance(device, Keybox)
        # errata K16: a pin in PWM reads HIGH, at duty 0 OFF
        note = _read_back(target, device, lambda: device.set_pwm(chosen, tenths), chosen,
                          "high" if tenths else "off", "PWM")
    names = " and ".join(str(pin) for pin in chosen)
    _done(target, f"output {names} PWM at {tenths * step} %")
    if note is not None:
        click.echo(note, err=True)


@keybox.command("states")
@bus_options
@node_id_option
@click.pass_obj
def states(target: Target) -> None:
    """Every output's state, and the input levels."""
    with _device(target) as device:
        assert isinstance(device, Keybox)
        outputs, inputs = device.states(), device.inputs()
        for pin in outputs:
            click.echo(f"pin {pin:>2}: {outputs[pin]:<5} input {'high' if inputs[pin] else 'low'}")


@keybox.command("faults")
@bus_options
@node_id_option
@click.pass_obj
def faults(target: Target) -> None:
    """The outputs in FAULT."""
    with _device(target) as device:
        assert isinstance(device, Keybox)
        found = [pin for pin, state in device.states().items() if state == "fault"]
        click.echo(", ".join(map(str, found)) if found else "no output in FAULT")


# -- what a model's face has besides keys and outputs (the PKP-3500-MT's knobs and inputs) -------

def _having(what: str, count: Callable[[Face], int]) -> Check:
    """A check that the model has some ``what`` on its face (encoders, inputs)."""

    def check(descriptions: Sequence[DeviceDescription]) -> None:
        if not any(count(d.face) for d in descriptions):
            raise ValueError(f"no {what}")

    return check


def _encoder_check(encoder: int, what: str = "encoders") -> Check:
    """ENCODER is one the model has (its face)."""
    having = _having(what, lambda face: len(face.encoders))

    def check(descriptions: Sequence[DeviceDescription]) -> None:
        having(descriptions)
        within("encoder", encoder, _encoders(descriptions))

    return check


def _led_list(text: str, encoder: int) -> list[int]:
    """"1,2,16" -> [1, 2, 16]; "off" or "" -> []."""
    if text.strip().lower() in ("", "off", "none"):
        return []

    def ring_leds(descriptions: Sequence[DeviceDescription]) -> Spans:
        return merged(spans_of(e.ring_leds) for d in descriptions for e in d.face.encoders
                      if e.number == encoder)

    return [_whole(f"ring {encoder} LED", part, ring_leds, "LEDS|off")
            for part in text.split(",") if part.strip()]


def _ring_leds(face: Face) -> list[int]:
    return [led for encoder in face.encoders for led in encoder.ring_leds]


@keypad.command("ring", epilog=f"Ring LEDs: {_per_model('keypad', _ring_leds)}.")
@click.argument("encoder", type=ModelNumber("encoder", _encoders))
@click.argument("leds", metavar="LEDS|off")
@bus_options
@node_id_option
@click.pass_obj
def ring(target: Target, encoder: int, leds: str) -> None:
    """Light exactly LEDS (comma-separated, numbered as the face) of ENCODER's ring; the
    other ring keeps its LEDs. ``off``: none.

    \b
    blinkcan keypad ring 1 1,2,3
    blinkcan keypad ring 2 off
    """
    chosen = _led_list(leds, encoder)
    has_encoder = _encoder_check(encoder, "encoder rings")

    def check(descriptions: Sequence[DeviceDescription]) -> None:
        has_encoder(descriptions)
        ring_leds = merged(spans_of(e.ring_leds) for d in descriptions
                           for e in d.face.encoders if e.number == encoder)
        for led in chosen:
            within(f"ring {encoder} LED", led, ring_leds)

    with _device(target, start=True, check=check) as device:
        device.read_rings()  # the other ring keeps what it shows (read from the keypad first)
        device.set_ring(encoder, chosen)
    shown = ", ".join(map(str, chosen)) if chosen else "off"
    _done(target, f"ring {encoder} LEDs {shown}")


@keypad.command("encoder")
@click.argument("encoder", type=ModelNumber("encoder", _encoders))
@click.option("--top", type=ModelNumber("TOP", _entries("encoder_{n}_top")), default=None,
              help="Store TOP: the counter stops at TOP clockwise and at 0 (0: it wraps).")
@click.option("--counter", type=ModelNumber("counter", _entries("encoder_{n}_ticks")),
              default=None,
              help="Store the counter the encoder starts from at power-on.")
@bus_options
@node_id_option
@click.pass_obj
def encoder_command(target: Target, encoder: int, top: int | None,
                    counter: int | None) -> None:
    """ENCODER's tick counter and TOP (read); --top and --counter store new ones first."""
    has_encoder = _encoder_check(encoder)

    def check(descriptions: Sequence[DeviceDescription]) -> None:
        has_encoder(descriptions)
        for what, value, name in (("TOP", top, f"encoder_{encoder}_top"),
                                  ("counter", counter, f"encoder_{encoder}_ticks")):
            entries = [d.table[name] for d in descriptions if name in d.table]
            if value is not None and not any(e.accepts(value) for e in entries):
                raise ValueError(f"{what} {value} outside {entries[0].describe_valid()}")

    with _device(target, check=check) as device:
        if top is not None:
            device.set_top(encoder, top)
        if counter is not None:
            device.set_startup_counter(encoder, counter)
        ticks = device.read_counter(encoder)
        stored_top = device.read(f"encoder_{encoder}_top")
    click.echo(f"encoder {encoder}: counter {ticks}, top {stored_top}")


@keypad.command("inputs")
@bus_options
@node_id_option
@click.pass_obj
def inputs(target: Target) -> None:
    """The analog inputs in volts and the digital inputs' levels (read)."""
    check = _having("inputs", lambda face: face.analog_inputs + face.digital_inputs)
    with _device(target, check=check) as device:
        face = device.description.face
        volts = {number: device.read_analog(number) for number in range(face.analog_inputs)}
        levels = device.digital_inputs() if face.digital_inputs else {}
    for number in sorted(set(volts) | set(levels)):
        parts = ([f"{volts[number]:.2f} V"] if number in volts else []) + (
            [f"digital {'high' if levels[number] else 'low'}"] if number in levels else [])
        click.echo(f"IN{number}: {', '.join(parts)}")


def _object_check(name: str, value: str | None = None) -> Check:
    """NAME is an object of the model (``export eds`` names); a VALUE to write is one that
    object takes."""

    def check(descriptions: Sequence[DeviceDescription]) -> None:
        entries = [d.table[name] for d in descriptions if name in d.table]
        if not entries:
            close = sorted({e.name for d in descriptions for e in d.table
                            if name.lower() in e.name})[:8]
            hint = f"; did you mean {', '.join(close)}" if close else ""
            raise ValueError(f"no object {name!r}{hint}")
        if value is None:
            return
        writable = [e for e in entries if e.access.writable]
        if not writable:
            entry = entries[0]
            raise ValueError(f"{entry.label} ({entry.index:04X}h/{entry.subindex:02X}) is "
                             "read-only")
        entry = writable[0]
        number: int | str = value
        if not entry.data_type.is_string:
            try:
                number = parse_int(value)
            except click.BadParameter:
                raise ValueError(f"{entry.label} ({entry.index:04X}h/{entry.subindex:02X}) "
                                 f"takes {entry.describe_valid()}, not {value!r}") from None
        if not any(e.accepts(number) for e in writable):
            raise ValueError(f"{entry.label} ({entry.index:04X}h/{entry.subindex:02X}) takes "
                             f"{entry.describe_valid()}, not {value}")

    return check


def _entry(device: Any, name: str) -> ObjectEntry:
    table = device.description.table
    if name not in table:
        close = [entry.name for entry in table if name.lower() in entry.name][:8]
        hint = f"; did you mean {', '.join(close)}" if close else ""
        raise click.ClickException(f"the {device.description.title} has no object {name!r}"
                                   f"{hint}")
    return table[name]  # type: ignore[no-any-return]
