"""Typed commands for ``blinkcan emulate``: a person at the terminal, or a script on a pipe,
acts on the emulated devices as the front panel does (``press 3``, ``turn 1 +5``,
``0Ch blow-fuse 4``, ``power-cycle``, ``help``, ``list``).

The vocabulary is the devices' faces: every action of ``twin/actions.py`` that a device's face
has, its name written with dashes (``blow-fuse``), plus timed pairs of them (``tap``: press,
hold, release; ``power-cycle``: power off, wait, power on) and ``wait``, ``help``, ``list``.
A command may start with the device it is for: its node id (15h, 0x15 or 21), its J1939
address, or its model name; without one it goes to the only emulated device that has that
action. Every action runs on the emulator's loop (``Emulator.run``), never on the reading
thread. A bad command is one ``Error:`` line naming what is valid, and the emulator runs on;
at the end of the input it keeps emulating until Ctrl-C.
"""

from __future__ import annotations

import contextlib
import errno
import os
import signal
import sys
import threading
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from types import MappingProxyType
from typing import IO

import click
from rich.console import Console

from blinkcan.cli.bus_options import parse_int
from blinkcan.cli.seconds import A_YEAR
from blinkcan.devices.model import Face
from blinkcan.devices.registry import model
from blinkcan.errors import BlinkcanError
from blinkcan.protocol.cob import check_time
from blinkcan.runtime import Emulator
from blinkcan.twin.actions import ACTIONS, Action, Argument
from blinkcan.twin.base import CanopenTwin
from blinkcan.twin.keypad import KeypadTwin

#: a line longer than this (a pipe that never sends a newline) is dropped, not kept growing
MAX_LINE = 4096
#: how often a reader in a background job (its terminal's reads refused) tries again, seconds
_BACKGROUND_RETRY_S = 0.5


@dataclass(frozen=True)
class Timed:
    """Two actions with a pause between them, as a hand does them (``tap``, ``power-cycle``)."""

    word: str
    doing: str
    first: str
    then: str
    pause: float


#: timed pairs of the face's actions, by the word typed
TIMED: MappingProxyType[str, Timed] = MappingProxyType({timed.word: timed for timed in (
    Timed("tap", "press a key, hold it SECONDS, release it", "press", "release", 0.1),
    Timed("power-cycle", "power off, SECONDS later power on", "power_off", "power_on", 0.1),
)})
#: what every emulator accepts besides the devices' actions
GENERAL = MappingProxyType({
    "help": "help [DEVICE]: what each device accepts",
    "list": "list: the emulated devices and their state",
    "wait": "wait SECONDS: pause the commands (in a script)",
})


class CommandError(BlinkcanError, ValueError):
    """A typed command that cannot be carried out; the message names what is valid."""


def word(action: str) -> str:
    """The typed word of an action: its name with dashes (blow_fuse -> blow-fuse)."""
    return action.replace("_", "-")


@dataclass(frozen=True)
class Device:
    """An emulated device as the commands address it: where it answers and what it is."""

    twin: CanopenTwin
    #: the address it answers at on its bus: the node id, or the J1939 source address
    address: int
    j1939: bool

    @property
    def face(self) -> Face:
        return self.twin.description.face

    @property
    def label(self) -> str:
        """"PKP-2600-SI keypad 15h", "PKP-2600-SI keypad 21h (J1939)"."""
        return f"{self.twin.description.title} {self.address:02X}h" + (
            " (J1939)" if self.j1939 else "")

    def words(self) -> list[str]:
        """The commands this device accepts, its face's actions first."""
        return [*(word(action.name) for action in ACTIONS.values() if action.fits(self.face)),
                *(timed.word for timed in TIMED.values() if _fits(timed, self.face))]


def _fits(timed: Timed, face: Face) -> bool:
    return ACTIONS[timed.first].fits(face) and ACTIONS[timed.then].fits(face)


def _device(twin: CanopenTwin) -> Device:
    """On the emulator's loop: where ``twin`` answers now (a J1939 address may move)."""
    if isinstance(twin, KeypadTwin) and twin.protocol == "j1939":
        return Device(twin, twin.j1939.address, True)
    return Device(twin, twin.node_id, False)


def _usage(typed: str, action: Action, face: Face, timed: Timed | None) -> str:
    """"press KEY (key 1..12)", "tap KEY [SECONDS] (key 1..12; SECONDS 0.1 if not given)"."""
    names = [argument.name.upper() for argument in action.arguments]
    ranges = [argument.describe(face) for argument in action.arguments]
    if timed is not None:
        names.append("[SECONDS]")
        ranges.append(f"SECONDS {timed.pause:g} if not given")
    return " ".join([typed, *names]) + (f" ({'; '.join(ranges)})" if ranges else "")


def _doing(typed: str) -> str:
    timed = TIMED.get(typed)
    return timed.doing if timed is not None else ACTIONS[typed.replace("-", "_")].doing


def _number(argument: Argument, face: Face, text: str) -> int | float:
    """The typed ``text`` as the argument's kind of number (ValueError naming the range)."""
    try:
        return int(text) if argument.is_integer(face) else float(text)
    except ValueError:
        low, high = argument.bounds(face)
        raise CommandError(f"{argument.name} must be {low}..{high}, not {text!r}") from None


def _seconds(text: str) -> float:
    """A typed pause: 0..a year (a longer one is a typo, and no timer reaches 1e300 s: the
    emulator's sleep overflowed after ``tap`` had pressed or ``power-cycle`` switched off)."""
    try:
        seconds = check_time("SECONDS", float(text), 0)
    except ValueError:
        raise CommandError(f"SECONDS must be a number >= 0, not {text!r}") from None
    if seconds > A_YEAR:
        raise CommandError(f"SECONDS must be 0..{A_YEAR:.10g}, not {text!r}")
    return seconds


class TypedCommands:
    """Carries out typed lines on ``emulator``'s devices: :meth:`execute` returns the lines to
    show (what was done, the help, or one ``Error:`` line) and never raises."""

    def __init__(self, emulator: Emulator) -> None:
        self.emulator = emulator

    @property
    def words(self) -> list[str]:
        """Every command word, whichever device has it."""
        return [*GENERAL, *(word(name) for name in ACTIONS), *TIMED]

    def execute(self, line: str) -> list[str]:
        """Carry out one typed line (``#`` starts a comment)."""
        tokens = line.partition("#")[0].split()
        if not tokens:
            return []
        try:
            return self._execute(tokens)
        except (ValueError, TypeError) as error:
            return [f"Error: {error}"]
        except Exception as error:  # a twin's fault must not end the commands
            return [f"Error: {type(error).__name__}: {error}"]

    def devices(self) -> list[Device]:
        """The emulated devices, read on the emulator's loop."""
        emulator = self.emulator
        return emulator.run(lambda now: [_device(twin) for twin in emulator.twins])

    # -- parsing ------------------------------------------------------------------------------

    def _execute(self, tokens: list[str]) -> list[str]:
        devices = self.devices()
        chosen = None
        if tokens[0].lower() not in self._known():
            chosen = self._select(tokens[0], devices)
            tokens = tokens[1:]
            if not tokens:
                raise CommandError(f"what should {chosen.label} do? It accepts "
                                   f"{', '.join(chosen.words())}")
        typed, arguments = tokens[0].lower().replace("_", "-"), tokens[1:]
        if typed == "help":
            return self._help([chosen] if chosen else devices, arguments, devices)
        if typed == "list":
            return self._list([chosen] if chosen else devices)
        if typed == "wait":
            if len(arguments) != 1:
                raise CommandError("usage: wait SECONDS")
            self.emulator.scheduler.sleep(_seconds(arguments[0]))
            return []
        if typed not in self._known():
            raise CommandError(f"unknown command {tokens[0]!r}; commands: "
                               f"{', '.join(self.words)}")
        timed = TIMED.get(typed)
        action = ACTIONS[timed.first if timed else typed.replace("-", "_")]
        try:
            device = chosen or self._only(typed, devices)
        except CommandError:
            if arguments and self._by_address(arguments[-1], devices):  # "power-cycle 0C"
                raise CommandError(f"the device goes first: {arguments[-1]} {typed} "
                                   f"{' '.join(arguments[:-1])}".rstrip()) from None
            raise
        if typed not in device.words():
            raise CommandError(f"the {device.label} has no {typed!r}; it accepts "
                               f"{', '.join(device.words())}")
        return self._act(device, typed, action, timed, arguments)

    def _known(self) -> set[str]:
        return {*self.words, *(name for name in ACTIONS)}

    def _select(self, text: str, devices: list[Device]) -> Device:
        """The device ``text`` names: an address (its node id, or its J1939 address) written
        15h, 0x15, or bare as the banner shows it (15: 15h, or 21 decimal where that is the
        only device it can mean), or its model's name or alias."""
        found = self._by_address(text, devices)
        if found is None:
            with contextlib.suppress(ValueError):
                name = model(text).name
                found = [d for d in devices if d.twin.description.model == name]
        if found is not None and len(found) == 1:
            return found[0]
        listed = ", ".join(d.label for d in devices)
        if found:
            named = ", ".join(d.label for d in found)
            raise CommandError(f"{text!r} names {len(found)} devices ({named}); start with the "
                               "address one answers at, as listed (15h or 0x15)")
        raise CommandError(f"unknown command or device {text!r}; commands: "
                           f"{', '.join(self.words)}; devices: {listed}")

    @staticmethod
    def _by_address(text: str, devices: list[Device]) -> list[Device] | None:
        """The devices at the address ``text`` (None: it is no number). A device answers at
        its address in use, and at its node id where no device uses that as its address."""
        numbers = set()
        with contextlib.suppress(click.BadParameter):
            numbers.add(parse_int(text))
        if not text.lower().startswith("0x") and not text.lower().endswith("h"):
            with contextlib.suppress(ValueError):
                numbers.add(int(text, 16))  # bare, as the banner and the frames show it
        if not numbers:
            return None
        found = [d for d in devices if d.address in numbers]
        return found or [d for d in devices if d.twin.node_id in numbers]

    def _only(self, typed: str, devices: list[Device]) -> Device:
        """The one device that accepts ``typed``, when the command names none."""
        able = [d for d in devices if typed in d.words()]
        if len(able) == 1:
            return able[0]
        if not able:
            accepted = "; ".join(f"{d.label}: {', '.join(d.words())}" for d in devices)
            raise CommandError(f"no emulated device has {typed!r} ({accepted})")
        raise CommandError(f"{typed}: which device? Start with its address, e.g. "
                           f"{able[0].address:02X}h {typed} ... ("
                           f"{', '.join(d.label for d in able)})")

    # -- doing --------------------------------------------------------------------------------

    def _act(self, device: Device, typed: str, action: Action, timed: Timed | None,
             texts: list[str]) -> list[str]:
        face = device.face
        wanted = len(action.arguments)
        if not (len(texts) == wanted or (timed is not None and len(texts) == wanted + 1)):
            raise CommandError(f"usage: {_usage(typed, action, face, timed)}")
        values = {argument.name: _number(argument, face, text)
                  for argument, text in zip(action.arguments, texts, strict=False)}
        arguments = action.check(face, values)
        twin = device.twin
        if timed is None:
            self.emulator.run(lambda now: action.perform(twin, arguments, now))
        else:
            pause = _seconds(texts[wanted]) if len(texts) > wanted else timed.pause
            then = ACTIONS[timed.then]
            self.emulator.run(lambda now: action.perform(twin, arguments, now))
            self.emulator.scheduler.sleep(pause)
            self.emulator.run(lambda now: then.perform(twin, arguments, now))
        done = ", ".join(f"{name} {value:+d}" if name == "ticks" else f"{name} {value}"
                         for name, value in arguments.items())
        return [f"{device.label}: {typed}" + (f" {done}" if done else "")]

    def _help(self, devices: list[Device], arguments: list[str],
              every: list[Device]) -> list[str]:
        if arguments:
            devices = [self._select(arguments[0], every)]
        lines = []
        for device in devices:
            lines.append(f"{device.label}, {device.twin.description.edition}:")
            for typed in device.words():
                timed = TIMED.get(typed)
                action = ACTIONS[timed.first if timed else typed.replace("-", "_")]
                lines.append(f"  {_usage(typed, action, device.face, timed)}: {_doing(typed)}")
        first = every[0]
        lines.append("Start a command with the device's address (15h, 0x15, or 15 as shown) or "
                     f"model name to pick it, e.g. {first.address:02X}h {first.words()[0]} ...; "
                     f"also: {'; '.join(GENERAL.values())}.")
        return lines

    def _list(self, devices: list[Device]) -> list[str]:
        states = self.emulator.run(lambda now: [_state(d.twin.snapshot()) for d in devices])
        return [f"{device.label}, {device.twin.description.edition}: {state}"
                for device, state in zip(devices, states, strict=True)]


def _state(snapshot: dict[str, object]) -> str:
    """"pre-operational", "off", or for a J1939 device (no NMT) its address claim."""
    j1939 = snapshot.get("j1939")
    if snapshot.get("protocol") == "j1939" and isinstance(j1939, dict) and snapshot["powered"]:
        return f"on (address claim: {j1939['address_claim']})"
    return str(snapshot["nmt_state"])


# -- reading the input -------------------------------------------------------------------------

@contextlib.contextmanager
def typed_commands(emulator: Emulator, console: Console,
                   stdin: IO[str] | None = None) -> Iterator[TypedCommands]:
    """While the body runs, read commands from ``stdin`` (the process's by default: a terminal
    or a pipe) in a thread of their own and carry them out; each one's lines go to
    ``console``. The end of the input ends the reading, not the body."""
    stream = sys.stdin if stdin is None else stdin
    commands = TypedCommands(emulator)
    read = _reader(stream)
    if read is None:
        yield commands
        return
    interactive = _is_terminal(stream)
    if interactive:
        console.print("Type commands here (help lists them); Ctrl-C stops.", markup=False)
    stopping = threading.Event()
    restore = _background_reads_refused() if interactive else None
    thread = threading.Thread(target=_serve, name="blinkcan-commands", daemon=True,
                              args=(commands, read, console, stopping, interactive))
    thread.start()
    try:
        yield commands
    finally:
        stopping.set()
        if restore is not None:
            restore()


def _reader(stream: IO[str] | None) -> Callable[[], bytes] | None:
    """A function returning the next bytes of ``stream`` (b"" at its end); None when there is
    no input at all. A stream with a descriptor is read with os.read: a thread blocked there
    holds no lock that the interpreter's exit waits for."""
    if stream is None or stream.closed:
        return None
    try:
        descriptor = stream.fileno()
    except (OSError, ValueError, AttributeError):  # a stream in memory (tests, embedding)
        return lambda: stream.readline().encode()
    return lambda: os.read(descriptor, MAX_LINE)


def _is_terminal(stream: IO[str]) -> bool:
    try:
        return stream.isatty()
    except (OSError, ValueError, AttributeError):
        return False


def _background_reads_refused() -> Callable[[], None] | None:
    """A job in the background reading its terminal is stopped by SIGTTIN (``blinkcan emulate
    keypad &`` would hang): ignored, such a read fails (EIO) and is tried again later.
    Returns what puts the previous handler back (None where there is no SIGTTIN, or off the
    main thread, where signals cannot be set)."""
    sigttin = getattr(signal, "SIGTTIN", None)
    if sigttin is None or threading.current_thread() is not threading.main_thread():
        return None
    previous = signal.signal(sigttin, signal.SIG_IGN)

    def restore() -> None:
        signal.signal(sigttin, signal.SIG_DFL if previous is None else previous)

    return restore


def _serve(commands: TypedCommands, read: Callable[[], bytes], console: Console,
           stopping: threading.Event, interactive: bool) -> None:
    """The reading thread: lines in, each carried out and answered, until the input ends."""
    pending = b""
    skipping = False  # the rest of a line too long to keep
    dropped = f"Error: a command longer than {MAX_LINE} characters was dropped"

    def show(lines: list[str]) -> None:
        if not stopping.is_set():
            for line in lines:
                console.print(line, markup=False, highlight=False, soft_wrap=True)

    while not stopping.is_set():
        try:
            chunk = read()
        except OSError as error:
            if error.errno == errno.EIO:  # a background job's terminal: try again later
                stopping.wait(_BACKGROUND_RETRY_S)
                continue
            show([f"Error: cannot read commands ({error}); still emulating, Ctrl-C stops"])
            return
        if not chunk:
            if pending.strip():
                show(commands.execute(pending.decode(errors="replace")))
            if interactive:
                show(["end of the commands; still emulating, Ctrl-C stops"])
            return
        *lines, pending = (pending + chunk).split(b"\n")
        if skipping and lines:  # the end of a line already dropped
            skipping, lines = False, lines[1:]
        for line in lines:
            if stopping.is_set():
                return
            show([dropped] if len(line) > MAX_LINE
                 else commands.execute(line.decode(errors="replace")))
        if len(pending) > MAX_LINE:
            if not skipping:
                show([dropped])
            skipping, pending = True, b""

