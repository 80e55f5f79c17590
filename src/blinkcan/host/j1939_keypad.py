"""The Keypad driver's J1939 side: commands and key messages of a PKP-2600-SI in J1939 mode.

:class:`~blinkcan.host.keypad.Keypad` keeps its API (``set_led``, ``events()``, brightness,
backlight, startup show, ...) in both protocols; in J1939 mode it sends through this link,
which builds every frame from ``devices/keypad_j1939.py`` (spec/pkp-2600-si-j1939.md; § are
Blink's J1939 manual's). LEDs go as single-LED commands (§7a), only for the keys that changed,
so they work in the keypad's default LED management mode (§13).
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from dataclasses import dataclass

import can

from blinkcan.devices.keypad_j1939 import (
    DEFAULT_HOST_ADDRESS,
    HEADER,
    HEARTBEAT,
    KEY_MESSAGE,
    KEY_PRESSED,
    KEYS,
    PGN_COMMAND,
    PRIORITY,
    SOFTWARE_REVISION_REPLY,
    TIME_UNIT_S,
    LedLook,
    LedState,
    channels_colour,
    command,
)
from blinkcan.devices.registry import models
from blinkcan.host.bus import HostBus
from blinkcan.host.device import BOOT_UP, NoDeviceError, seconds_spans
from blinkcan.host.identity_errors import SharedNodeIdError
from blinkcan.host.waits import check_wait
from blinkcan.protocol.frame import Frame
from blinkcan.protocol.j1939 import (
    ADDRESS_MAX,
    CLAIM_TIMEOUT_S,
    GLOBAL_ADDRESS,
    NULL_ADDRESS,
    PGN_ADDRESS_CLAIMED,
    PGN_REQUEST,
    compose_id,
    parse_id,
    request_frame,
)

#: CANopen object names the driver writes -> the J1939 command setting the same thing
SETTING_COMMANDS = {
    "startup_led_show": "startup_led_show",
    "demo_mode": "demo_mode",
    "backlight_colour": "backlight_colour",
    "default_backlight_colour": "backlight_colour",
    "startup_indicator_brightness": "startup_led_brightness",
    "startup_backlight_brightness": "startup_backlight_level",
}


def look_of(on: int, blink: int) -> LedLook:
    """The §7a command for one key of the driver's picture: phase A shows ``on``, phase B the
    channels ``blink`` toggles (PKP §12, the twin's model in both protocols)."""
    phase_a, phase_b = on & 7, (on ^ blink) & 7
    first, second = channels_colour(phase_a), channels_colour(phase_b)
    if phase_a == phase_b:
        return LedLook(LedState.ON if first else LedState.OFF, first)
    if not phase_b or not phase_a:
        return LedLook(LedState.BLINK, first or second)
    return LedLook(LedState.ALTERNATE, first, second)


#: What the link tells the driver: a heartbeat was heard (§18; the driver's watch says "lost"
#: and "back"), the keypad powered on (device.py's "boot-up"), lost its address, moved
HEARD = "heartbeat"
ADDRESS_LOST = "address lost"  # another node with a lower NAME claimed the keypad's address
MOVED = "moved"  # the keypad claimed another address (J-5): the driver follows it there
#: the first heartbeat heard (§18): its counter starts at 00h both when the heartbeat is turned
#: on and when the keypad powers on with it stored on, so a power-on before it cannot be told:
#: what the keypad shows is unknown (no health event: it may be no power-on)
UNKNOWN = "state unknown"


def _period_byte(command_name: str, what: str, ms: int) -> int:
    """``ms`` as the period byte of a J1939 command (x 10 ms, §17/§18); a period the byte
    cannot carry is a ValueError naming the valid periods in seconds, before anything is
    sent."""
    valid = next(each.valid for each in command(command_name).fields if each.name == "period")
    units = round(ms / 1000 / TIME_UNIT_S)
    if units not in valid:
        raise ValueError(f"{what} must be 0 or {seconds_spans(valid.spans, TIME_UNIT_S)} s "
                         f"in J1939 mode (§17/§18), not {ms / 1000:g}")
    return units


class KeypadGoneError(NoDeviceError):
    """The keypad lost its address to another node's claim and has not been heard at a new
    one (J-5): the driver sends nothing, so that it never commands the other node."""


@dataclass(frozen=True)
class J1939Identity:
    """What a keypad in J1939 mode tells about itself: its source address, software revision
    (§11), NAME (§20, hex; None when it has not claimed an address), claim state, and its last
    heartbeat (§18; None when none was heard within ``heartbeat_wait`` seconds)."""

    address: int
    model: str  # the registered model, as its description names it (as Identity.model)
    software_version: str
    name: str | None
    claim: str
    heartbeat: str | None
    heartbeat_wait: float = 0.0


def heartbeat_period_default() -> float:
    """Seconds between heartbeats at the keypad's default period (§18, 75h: 0Ah x 10 ms)."""
    period = next(f for f in command("heartbeat").fields if f.name == "period")
    assert period.default is not None
    return period.default * TIME_UNIT_S


class J1939KeypadLink:
    """Frames to and from the keypad at ``address``; ``on_key(key, pressed, now)`` is called
    on the bus's loop for each key message (§6), ``on_health(kind, address, now)`` when the
    keypad moves, loses its address, comes back or powers on. Thread-safe: the LED looks sent
    change under a lock, and one software revision request is outstanding at a time.

    The keypad is followed by its NAME (§20, J-5): a lower NAME claiming its address makes it
    move, and its own claim says where; until then (or after "cannot claim") nothing is sent.
    It powered on when it claims its address unasked, or its heartbeat counter starts at 00h
    again (§18: +1 per message, J-6 wraps FFh to 00h); the first heartbeat heard is
    ``UNKNOWN`` (it may follow a power-on the counter cannot show)."""

    def __init__(self, host: HostBus, address: int, on_key: Callable[[int, bool, float], None],
                 source: int = DEFAULT_HOST_ADDRESS,
                 on_health: Callable[[str, int, float], None] | None = None) -> None:
        if not 1 <= address <= ADDRESS_MAX:
            raise ValueError(f"J1939 keypad address must be 0x01..{ADDRESS_MAX:#04x}, not "
                             f"{address:#x}")
        self.host = host
        self.address = address
        self.source = source
        self._on_key = on_key
        self._on_health = on_health or (lambda kind, address, now: None)
        self._looks: dict[int, LedLook] = {}
        self._looks_lock = threading.RLock()
        self._revision: str | None = None
        self._revision_signal = host.signal()
        self._revision_lock = threading.Lock()
        self._heard_signal = host.signal()
        self._heartbeat_signal = host.signal()
        #: software revision replies since :meth:`confirm` asked, the time of the first, and
        #: a signal set at the second (a second keypad at the address)
        self._revision_replies = 0
        self._first_reply_at = 0.0
        self._second_reply = host.signal()
        #: the keypad's NAME once it claimed an address (§20), else None
        self.name: bytes | None = None
        #: "not claimed" (address claim off, §20), "claimed", or "lost to <NAME>"
        self.claim = "not claimed"
        self.gone = False
        self.heartbeat: tuple[int, int] | None = None  # (counter, keys held) of the last one
        self._requested_claims = -1.0  # when someone last asked for claims (answers are no boot)
        self._unsubscribe = host.subscribe_extended(self._on_frame)

    def close(self) -> None:
        self._unsubscribe()

    def send(self, name: str, *values: int) -> None:
        """Command ``name`` of devices/keypad_j1939.py (ValueError before anything is sent;
        :class:`KeypadGoneError` while the keypad has no address, J-5)."""
        data = command(name).encode(*values)
        if self.gone:
            raise KeypadGoneError(self._gone_text())
        self.host.send(Frame(compose_id(PGN_COMMAND, self.source, self.address, PRIORITY),
                             data, extended=True))

    def _gone_text(self) -> str:
        return (f"the J1939 keypad lost its address {self.address:02X}h ({self.claim}) and "
                "has not claimed another: nothing sent")

    def confirm(self, timeout: float) -> None:
        """Make sure a keypad is at the address before the first command (J1939 commands are
        unacknowledged): a Request for Address Claimed and a software revision request (§11,
        §20); its revision, heartbeat or key message answers. :class:`NoDeviceError`
        otherwise."""
        check_wait("timeout", timeout, self.host)  # before anything is sent
        with self._revision_lock:  # no software_revision() request in between
            self._heard_signal.clear()
            self._revision_signal.clear()
            self._second_reply.clear()
            self._revision_replies = 0
            asked = self._requested_claims = self.host.clock()
            self.host.send(request_frame(PGN_ADDRESS_CLAIMED, self.source, self.address))
            self.send("software_revision")
            if not self.host.wait(self._heard_signal, timeout):
                raise NoDeviceError(f"no keypad heard at {self.address:02X}h")
            self._check_one_keypad(asked)

    def _check_one_keypad(self, asked: float) -> None:
        """:class:`SharedNodeIdError` when two keypads answer the one software revision
        request (two keypads at one address, as CANopen's two devices at one node id: every
        command reaches both). The second answer comes about as late as the first: it is
        waited for twice as long again as the first took (in simulated time with no latency,
        no time at all: the answers due at this instant). A keypad heard by its heartbeat or a
        key before its reply is not counted (nothing is waited for)."""
        if not self._revision_signal.is_set():
            return
        self.host.wait(self._second_reply, 2 * max(0.0, self._first_reply_at - asked))
        answers = self._revision_replies
        if answers > 1:
            word = {2: "two", 3: "three", 4: "four"}.get(answers, str(answers))
            raise SharedNodeIdError(
                f"{word} keypads answer at J1939 address {self.address:02X}h (one software "
                f"revision request got {answers} replies): give each its own address "
                "(address claim, 74h, moves one of them)", answers)

    def forget_looks(self) -> None:
        """The keypad shows nothing now (it powered on): the next show sends every look."""
        with self._looks_lock:
            self._looks.clear()

    def show(self, looks: dict[int, LedLook], force: bool = False) -> None:
        """Send a single-LED command (§7a) for every key in ``looks`` whose look changed (every
        one with ``force``); keys not in ``looks`` are not touched."""
        with self._looks_lock:
            for key, look in sorted(looks.items()):
                if force or self._looks.get(key) != look:
                    self.send("single_led", key, look.colour, int(look.state), look.secondary)
                    self._looks[key] = look

    def write(self, name: str, value: int) -> None:
        """A CANopen setting the driver writes, as its J1939 command."""
        if name == "tpdo1_event_timer":  # periodic key state (§17): 0 = off, else x 10 ms
            if value:
                self.send("key_message_period",
                          _period_byte("key_message_period", "key state period", value))
            self.send("periodic_key_state", int(bool(value)))
            return
        if name == "producer_heartbeat_time":  # §18: on and period x 10 ms; 0 = off
            period = _period_byte("heartbeat", "heartbeat period", value) if value else 0xFF
            self.send("heartbeat", int(bool(value)), period)
            return
        if name not in SETTING_COMMANDS:
            raise ValueError(f"{name} is a CANopen setting; in J1939 mode use "
                             "keypad.j1939.send(<command>, ...) (devices/keypad_j1939.py)")
        self.send(SETTING_COMMANDS[name], value)

    def software_revision(self, timeout: float = 0.5) -> str:
        """Ask the keypad for its software revision (§11); callers in other threads wait
        their turn (the reply names no request)."""
        check_wait("timeout", timeout, self.host)  # before anything is sent
        with self._revision_lock:
            self._revision = None
            self._revision_signal.clear()
            self.send("software_revision")
            if not self.host.wait(self._revision_signal, timeout) or self._revision is None:
                raise TimeoutError(f"J1939 keypad {self.address:02X}h did not answer within "
                                   f"{timeout} s")
            return self._revision

    def identity(self, model: str, timeout: float = 0.5,
                 heartbeat_wait: float | None = None) -> J1939Identity:
        """What the keypad tells (J1939Identity); its heartbeat, when none was heard yet, is
        waited for up to ``heartbeat_wait`` seconds (default: one and a half periods at the
        keypad's default period, §18), so a heartbeat that is on is not called "not heard"."""
        if heartbeat_wait is not None:
            check_wait("heartbeat_wait", heartbeat_wait, self.host)
        revision = self.software_revision(timeout)
        # one period and a half: a heartbeat due as the wait starts may come a little late
        wait = 1.5 * heartbeat_period_default() if heartbeat_wait is None else heartbeat_wait
        if self.heartbeat is None and wait > 0:
            self._heartbeat_signal.clear()
            self.host.wait(self._heartbeat_signal, wait)
        heartbeat = None
        if self.heartbeat is not None:
            counter, keys = self.heartbeat
            held = [str(key) for key in range(1, KEYS + 1) if keys >> (key - 1) & 1]
            heartbeat = f"counter {counter:02X}h, keys held: {', '.join(held) or 'none'}"
        return J1939Identity(self.address, model, revision,
                             self.name.hex(" ").upper() if self.name is not None else None,
                             self.claim, heartbeat, wait)

    def _on_frame(self, frame: Frame, now: float) -> None:
        ident = parse_id(frame.can_id)
        data = frame.data
        if ident.pgn == PGN_REQUEST and len(data) >= 3 and \
                int.from_bytes(data[:3], "little") == PGN_ADDRESS_CLAIMED:
            self._requested_claims = now  # J1939-81: claims that follow answer it
            return
        if ident.pgn == PGN_ADDRESS_CLAIMED and len(data) == 8:
            self._on_claim(ident.source, bytes(data), now)
            return
        if ident.pgn != PGN_COMMAND or ident.source != self.address or self.gone or \
                len(data) != 8 or data[:2] != HEADER:
            return
        if data[2] == KEY_MESSAGE and 1 <= data[3] <= KEYS:  # §6
            self._heard_signal.set()
            self._on_key(data[3], data[4] == KEY_PRESSED, now)
        elif data[2] == SOFTWARE_REVISION_REPLY and data[3] != 0xFF:  # §11
            self._revision_replies += 1
            if self._revision_replies == 1:
                self._first_reply_at = now
            else:
                self._second_reply.set()
            self._revision = data[3:7].rstrip(b"\x00").decode("ascii", "replace")
            self._revision_signal.set()
            self._heard_signal.set()
        elif data[2] == HEARTBEAT:  # §18
            self._heard_signal.set()
            before = self.heartbeat
            self.heartbeat = (data[3], data[4] | (data[5] & 0x0F) << 8)
            self._heartbeat_signal.set()
            self._on_health(HEARD, self.address, now)
            if before is None:
                self._on_health(UNKNOWN, self.address, now)
            elif data[3] == 0 and before[0] != 0xFF:  # J-6: 00h after FFh is a wrap
                self._on_health(BOOT_UP, self.address, now)

    def _on_claim(self, source: int, name: bytes, now: float) -> None:
        """§20, J-5: follow the keypad by its NAME."""
        if self.name is None and source == self.address:
            self.name = name  # the first claim from its address: the keypad's NAME
        if name != self.name:
            if source == self.address and not self.gone:  # a lower NAME took the address
                self.gone = True
                self.claim = f"lost to {name.hex(' ').upper()}"
                self._on_health(ADDRESS_LOST, self.address, now)
            return
        self._heard_signal.set()
        if source == NULL_ADDRESS:  # J-5: cannot claim, silent from now on
            if not self.gone:
                self._on_health(ADDRESS_LOST, self.address, now)
            self.gone, self.claim = True, "cannot claim"
            return
        moved = source != self.address
        answering = now - self._requested_claims <= CLAIM_TIMEOUT_S
        self.address, self.gone, self.claim = source, False, "claimed"
        if moved:
            self._on_health(MOVED, source, now)
        elif not answering:  # a claim nobody asked for: it powered on (§20 "at start-up")
            self._on_health(BOOT_UP, source, now)


@dataclass(frozen=True)
class FoundJ1939:
    """A keypad in J1939 mode that answered: its source address, software revision (§11) and,
    if it claimed its address (§20), its NAME as hex. ``model``: the registered model (as
    ``Found.model``), when one registered model has a J1939 mode (J1939 tells no model id);
    None when several have."""

    address: int
    software_revision: str | None = None
    name: str | None = None
    #: keypads that told their revision from this address: more than one share it (a mistake
    #: address claim, when on, resolves by moving one, J-5)
    answers: int = 1
    model: str | None = None


def j1939_models() -> list[str]:
    """The registered models (their names) with a J1939 mode, from their descriptions."""
    return [found.name for found in models()
            if any("j1939" in found.description(g).features for g in found.generations)]


def scan_j1939(bus: HostBus | can.BusABC, listen: float = 0.3,
               source: int = DEFAULT_HOST_ADDRESS) -> list[FoundJ1939]:
    """Keypads in J1939 mode on ``bus``: a Request for Address Claimed and a software revision
    request, both to all (J-2), and the answers heard within ``listen`` seconds."""
    host = HostBus.attach(bus)
    revisions: dict[int, str] = {}
    answers: dict[int, int] = {}
    names: dict[int, str] = {}

    def hear(frame: Frame, now: float) -> None:
        ident = parse_id(frame.can_id)
        data = frame.data
        if ident.pgn == PGN_ADDRESS_CLAIMED and len(data) == 8 and ident.source <= ADDRESS_MAX:
            names[ident.source] = data.hex()
        elif (ident.pgn == PGN_COMMAND and len(data) == 8 and data[:2] == HEADER
              and data[2] == SOFTWARE_REVISION_REPLY and data[3] != 0xFF):
            revisions[ident.source] = data[3:7].rstrip(b"\x00").decode("ascii", "replace")
            answers[ident.source] = answers.get(ident.source, 0) + 1

    remove = host.subscribe_extended(hear)
    try:
        host.send(request_frame(PGN_ADDRESS_CLAIMED, source))
        host.send(Frame(compose_id(PGN_COMMAND, source, GLOBAL_ADDRESS, PRIORITY),
                        command("software_revision").encode(), extended=True))
        host.sleep(listen)
    finally:
        remove()
        host.release()
    # a claim alone may be another J1939 node: a keypad is one that told its revision
    having = j1939_models()
    model = having[0] if len(having) == 1 else None
    return [FoundJ1939(address, revisions[address], names.get(address), answers[address], model)
            for address in sorted(revisions)]
