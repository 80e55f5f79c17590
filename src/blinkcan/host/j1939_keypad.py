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

from blinkcan.devices.colours import Channel
from blinkcan.devices.keypad_j1939 import (
    DEFAULT_HOST_ADDRESS,
    HEADER,
    KEY_MESSAGE,
    KEY_PRESSED,
    KEYS,
    PGN_COMMAND,
    PRIORITY,
    SOFTWARE_REVISION_REPLY,
    TIME_UNIT_S,
    LedLook,
    LedState,
    command,
)
from blinkcan.host.bus import HostBus
from blinkcan.protocol.frame import Frame
from blinkcan.protocol.j1939 import (
    ADDRESS_MAX,
    GLOBAL_ADDRESS,
    PGN_ADDRESS_CLAIMED,
    compose_id,
    parse_id,
    request_frame,
)

#: Channels of a key's LEDs -> the §7a colour code that lights them (amber and yellow/green
#: light the same channels as yellow on these LEDs, J-4).
COLOUR_OF_CHANNELS = {
    Channel.NONE: 0x00, Channel.RED: 0x01, Channel.GREEN: 0x02, Channel.BLUE: 0x03,
    Channel.RED | Channel.GREEN: 0x04, Channel.GREEN | Channel.BLUE: 0x05,
    Channel.RED | Channel.BLUE: 0x06, Channel.RED | Channel.GREEN | Channel.BLUE: 0x07,
}

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
    first, second = COLOUR_OF_CHANNELS[Channel(phase_a)], COLOUR_OF_CHANNELS[Channel(phase_b)]
    if phase_a == phase_b:
        return LedLook(LedState.ON if first else LedState.OFF, first)
    if not phase_b or not phase_a:
        return LedLook(LedState.BLINK, first or second)
    return LedLook(LedState.ALTERNATE, first, second)


class J1939KeypadLink:
    """Frames to and from the keypad at ``address``; ``on_key(key, pressed, now)`` is called
    on the bus's loop for each key message (§6). Thread-safe: the LED looks sent change under
    a lock, and one software revision request is outstanding at a time."""

    def __init__(self, host: HostBus, address: int, on_key: Callable[[int, bool, float], None],
                 source: int = DEFAULT_HOST_ADDRESS) -> None:
        if not 1 <= address <= ADDRESS_MAX:
            raise ValueError(f"J1939 keypad address must be 0x01..{ADDRESS_MAX:#04x}, not "
                             f"{address:#x}")
        self.host = host
        self.address = address
        self.source = source
        self._on_key = on_key
        self._looks: dict[int, LedLook] = {}
        self._looks_lock = threading.RLock()
        self._revision: str | None = None
        self._revision_signal = host.signal()
        self._revision_lock = threading.Lock()
        self._unsubscribe = host.subscribe_extended(self._on_frame)

    def close(self) -> None:
        self._unsubscribe()

    def send(self, name: str, *values: int) -> None:
        """Command ``name`` of devices/keypad_j1939.py (ValueError before anything is sent)."""
        data = command(name).encode(*values)
        self.host.send(Frame(compose_id(PGN_COMMAND, self.source, self.address, PRIORITY),
                             data, extended=True))

    def show(self, looks: dict[int, LedLook], force: bool = False) -> None:
        """Send a single-LED command for every key whose look changed."""
        with self._looks_lock:
            for key, look in sorted(looks.items()):
                if force or self._looks.get(key) != look:
                    self.send("single_led", key, look.colour, int(look.state), look.secondary)
                    self._looks[key] = look

    def write(self, name: str, value: int) -> None:
        """A CANopen setting the driver writes, as its J1939 command."""
        if name == "tpdo1_event_timer":  # periodic key state (§17): 0 = off, else x 10 ms
            if value:
                self.send("key_message_period", round(value / 1000 / TIME_UNIT_S))
            self.send("periodic_key_state", int(bool(value)))
            return
        if name not in SETTING_COMMANDS:
            raise ValueError(f"{name} is a CANopen setting; in J1939 mode use "
                             "keypad.j1939.send(<command>, ...) (devices/keypad_j1939.py)")
        self.send(SETTING_COMMANDS[name], value)

    def software_revision(self, timeout: float = 0.5) -> str:
        """Ask the keypad for its software revision (§11); callers in other threads wait
        their turn (the reply names no request)."""
        with self._revision_lock:
            self._revision = None
            self._revision_signal.clear()
            self.send("software_revision")
            if not self.host.wait(self._revision_signal, timeout) or self._revision is None:
                raise TimeoutError(f"J1939 keypad {self.address:02X}h did not answer within "
                                   f"{timeout} s")
            return self._revision

    def _on_frame(self, frame: Frame, now: float) -> None:
        ident = parse_id(frame.can_id)
        data = frame.data
        if ident.pgn != PGN_COMMAND or ident.source != self.address or len(data) != 8 or \
                data[:2] != HEADER:
            return
        if data[2] == KEY_MESSAGE and 1 <= data[3] <= KEYS:  # §6
            self._on_key(data[3], data[4] == KEY_PRESSED, now)
        elif data[2] == SOFTWARE_REVISION_REPLY and data[3] != 0xFF:  # §11
            self._revision = data[3:7].rstrip(b"\x00").decode("ascii", "replace")
            self._revision_signal.set()


@dataclass(frozen=True)
class FoundJ1939:
    """A keypad in J1939 mode that answered: its source address, software revision (§11) and,
    if it claimed its address (§20), its NAME as hex."""

    address: int
    software_revision: str | None = None
    name: str | None = None
    #: keypads that told their revision from this address: more than one share it (a mistake
    #: address claim, when on, resolves by moving one, J-5)
    answers: int = 1


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
    return [FoundJ1939(address, revisions[address], names.get(address), answers[address])
            for address in sorted(revisions)]
