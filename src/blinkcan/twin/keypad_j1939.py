"""The PKP-2600-SI's J1939 personality (spec/pkp-2600-si-j1939.md, "§" = Blink's J1939 manual).

:class:`KeypadTwin` hands every extended frame, key change and timer to this object while the
keypad is in J1939 mode. It runs on the command tables of ``devices/keypad_j1939.py`` and on the
same LED picture, blink model, startup show and DEMO mode as CANopen mode (J-4: same hardware).

Decisions beyond J-1..J-7 (blinkcan's, where the manual is silent):
- Every message from the keypad (key states, heartbeat, software revision, LED acknowledge) goes
  to the destination address of 6Eh (default FFh): the manual prints them all on ``18EFFF21h``.
- A command must be 8 bytes with the ``04 1B`` header and FFh in its unused bytes (§4); so a
  keypad never takes another keypad's messages to all (FFh) for commands
  (``J1939Command.decode``).
- A multiple-LED frame sets the colour-1 or colour-2 nibbles of all 12 LEDs; each LED shows the
  pair it holds (§7b). A single-LED command clears that LED's nibbles.
- With address claim (74h) off the keypad takes no part in address claiming; with it on, a
  changed source address (70h) is claimed at once. An address moved to by a conflict is used
  until the next power-on, which claims the stored address again.
- Key message at start-up (28h): at power-on the 12 key states are sent once, keys 1-12.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from typing import Any

from blinkcan.devices.colours import BacklightColour, Channel
from blinkcan.devices.keypad import FACE
from blinkcan.devices.keypad_j1939 import (
    BITRATES,
    COMMANDS_BY_CODE,
    HEADER,
    PGN_COMMAND,
    PGN_LEDS_COLOUR_1,
    PGN_LEDS_COLOUR_2,
    POWER_ON_FROM,
    PRIORITY,
    SOFTWARE_REVISION,
    TIME_UNIT_S,
    J1939Command,
    LedLook,
    LedState,
    default_settings,
    heartbeat_message,
    key_message,
    led_acknowledge,
    look_channels,
    look_phases,
    nibbles_to_look,
    software_revision_message,
    split_nibbles,
)
from blinkcan.protocol.frame import Frame
from blinkcan.protocol.j1939 import (
    GLOBAL_ADDRESS,
    PGN_ADDRESS_CLAIMED,
    PGN_REQUEST,
    AddressClaimer,
    ClaimState,
    J1939Name,
    compose_id,
    parse_id,
)
from blinkcan.twin.keypad_display import (
    SHOW_NAMES,
    STARTUP_SHOWS,
    DemoMode,
    ShowPlayer,
    displayed_words,
    fill,
    render_key,
)
from blinkcan.twin.schedule import Ticker, ticks

_KEYS = FACE.keys  # the PKP-2600-SI's keys (its J1939 mode, pkp-2600-si-j1939.md)
_KEY_BITS = (1 << _KEYS) - 1
_LED_PGNS = (PGN_LEDS_COLOUR_1, PGN_LEDS_COLOUR_2)
_UNIT = ticks(TIME_UNIT_S)  # §17/§18: the periods count 10 ms


def _clear_key(word: int, key: int) -> int:
    return word & ~fill(1 << (key - 1), Channel.RED | Channel.GREEN | Channel.BLUE)


class J1939Keypad:
    """The keypad while it speaks J1939. ``settings`` are the stored J1939 settings (names
    of ``devices/keypad_j1939.STORED_SETTINGS``); ``save`` stores them as they are to become
    and says whether it could: a setting the NVM cannot take is not changed (nothing is
    answered on J1939 either way).
    """

    def __init__(self, name: J1939Name, settings: dict[str, int],
                 save: Callable[[dict[str, int]], bool], speaks: bool = True) -> None:
        #: False for a model whose J1939 mode is not documented (PKP-3500-MT, MT M82): it is
        #: silent and answers only the way back (errata "Protocol switch")
        self.speaks = speaks
        self.name = name
        self.settings = {**default_settings(), **settings}
        self._save = save
        self.wants_canopen = False  # 80h received: the twin reboots into CANopen
        self._powered = False
        self._now = 0.0
        self._bitrate_code = self.settings["baud_rate"]
        self.address = self.settings["source_address"]
        self._keys = 0
        self._words = {"led_on": 0, "led_blink": 0}
        #: key -> the §7a look commanded: its colour codes as sent (amber is not yellow)
        self._looks: dict[int, LedLook] = {}
        self._nibbles = ([0] * _KEYS, [0] * _KEYS)
        self._live = {"led_brightness": 0, "backlight_level": 0}
        self._claimer: AddressClaimer | None = None
        self._heartbeat_timer = Ticker()  # §18
        self._heartbeat_counter = 0
        self._periodic_timer = Ticker()  # §17
        self._show: ShowPlayer | None = None
        self._demo: DemoMode | None = None
        self._handlers: dict[int, Callable[[J1939Command, dict[str, int], float], list[Frame]]]
        self._handlers = {
            0x01: self._single_led, 0x02: self._live_level, 0x03: self._live_level,
            0x2A: self._software_revision, 0x6E: self._store_only, 0x6F: self._store_only,
            0x70: self._source_address, 0x71: self._key_timing, 0x72: self._store_only,
            0x73: self._store_only, 0x74: self._store_only, 0x75: self._heartbeat,
            0x77: self._key_timing, 0x7A: self._demo_mode, 0x7D: self._store_only,
            0x80: self._switch_to_canopen,
        }

    # -- power ----------------------------------------------------------------------------------

    def power_on(self, now: float, keys: int = 0) -> list[Frame]:
        self._powered = True
        self._now = now
        self.wants_canopen = False
        if not self.speaks:
            self._keys = keys
            return []
        settings = self.settings
        self._bitrate_code = settings["baud_rate"]  # §15, J-3: applied at power-on
        self.address = settings["source_address"]
        self._keys = keys
        self._words = {"led_on": 0, "led_blink": 0}
        self._looks = {}
        self._nibbles = ([0] * _KEYS, [0] * _KEYS)
        self._live = {live: settings[stored] for live, stored in POWER_ON_FROM.items()}
        steps = STARTUP_SHOWS.get(settings["startup_led_show"])  # §12
        self._show = ShowPlayer(steps, now) if steps is not None else None
        self._demo = DemoMode(now) if settings["demo_mode"] else None  # §22: at power-on
        self._heartbeat_counter = 0
        self._schedule_heartbeat(now)
        self._schedule_periodic(now)
        frames: list[Frame] = []
        self._claimer = None
        if settings["address_claim"]:  # §20
            self._claimer = AddressClaimer(self.name, self.address)
            frames += self._claimer.start(now)
        if settings["key_message_at_startup"]:  # §10
            frames += self._all_key_messages()
        return frames

    def power_off(self) -> None:
        self._powered = False
        self._claimer = None
        self._heartbeat_timer.stop()
        self._periodic_timer.stop()
        self._show = self._demo = None

    @property
    def bitrate(self) -> int:
        return BITRATES[self._bitrate_code]

    @property
    def silent(self) -> bool:
        """J-5: after "cannot claim" the keypad sends nothing."""
        return self._claimer is not None and self._claimer.state is ClaimState.CANNOT_CLAIM

    # -- frames in ------------------------------------------------------------------------------

    def receive(self, frame: Frame, now: float) -> list[Frame]:
        if not self._powered or not frame.extended:
            return []
        self._now = now
        ident = parse_id(frame.can_id)
        if ident.pgn in (PGN_ADDRESS_CLAIMED, PGN_REQUEST):
            if self._claimer is None:
                return []
            frames = self._claimer.receive(frame, now)
            self.address = self._claimer.address
            return frames
        if ident.destination not in (self.address, GLOBAL_ADDRESS) or self.silent:
            return []  # J-2: another keypad's, or not ours to act on
        if ident.pgn == PGN_COMMAND:
            return self._on_command(frame.data, now)
        if ident.pgn in _LED_PGNS:
            return self._on_multiple_leds(_LED_PGNS.index(ident.pgn), frame.data)
        return []

    def _on_command(self, data: bytes, now: float) -> list[Frame]:
        if len(data) != 8 or data[:2] != HEADER:
            return []  # J-2: malformed, no change, no answer
        command = COMMANDS_BY_CODE.get(data[2])
        if command is None or (not self.speaks and command.name != "switch_to_canopen"):
            return []
        fields = command.decode(data)
        if fields is None:
            return []
        if self._demo is not None and command.name != "demo_mode":
            self._demo = None  # §22: "any other command" leaves DEMO mode
        handler = self._handlers.get(command.code, self._store_only)
        return handler(command, fields, now)

    def _on_multiple_leds(self, which: int, data: bytes) -> list[Frame]:
        # §7b: only in LED management mode 02h (§13); 8 bytes, LEDs in nibbles
        if not self.speaks or self.settings["led_management"] != 0x02 or len(data) != 8:
            return []
        self._demo = None
        self._nibbles[which][:] = split_nibbles(data)
        for key in range(1, _KEYS + 1):
            self._show_look(key, nibbles_to_look(self._nibbles[0][key - 1],
                                                 self._nibbles[1][key - 1]))
        return []

    # -- commands -------------------------------------------------------------------------------

    def _store(self, command: J1939Command, fields: dict[str, int]) -> None:
        wanted = dict(self.settings)
        for field in command.fields:
            value = fields[field.name]
            if field.setting is not None and value != field.keep:
                wanted[field.setting] = value
        # an unchanged value is not written again; one the NVM cannot take is not changed
        if wanted != self.settings and self._save(wanted):
            self.settings = wanted

    def _store_only(self, command: J1939Command, fields: dict[str, int],
                    now: float) -> list[Frame]:
        self._store(command, fields)
        return []

    def _single_led(self, command: J1939Command, fields: dict[str, int],
                    now: float) -> list[Frame]:
        key, state = fields["key"], fields["state"]
        secondary = fields["secondary"]
        for nibbles in self._nibbles:
            nibbles[key - 1] = 0
        self._show_look(key, LedLook(LedState(state), fields["colour"], secondary))
        if not self.settings["led_acknowledge"]:  # §19
            return []
        return self._send(led_acknowledge(state, key, fields["colour"], fields["secondary"]))

    def _show_look(self, key: int, look: LedLook) -> None:
        """One LED in the CANopen picture's terms (PKP §12 phases): on = phase A colour,
        blink = the channels that change in phase B."""
        self._looks[key] = look
        on, blink = look_channels(look)
        bit = 1 << (key - 1)
        self._words["led_on"] = _clear_key(self._words["led_on"], key) | fill(bit, on)
        self._words["led_blink"] = _clear_key(self._words["led_blink"], key) | fill(bit, blink)

    def _live_level(self, command: J1939Command, fields: dict[str, int],
                    now: float) -> list[Frame]:
        self._live[command.fields[0].setting or command.name] = fields["level"]  # §8/§9
        return []

    def _software_revision(self, command: J1939Command, fields: dict[str, int],
                           now: float) -> list[Frame]:
        return self._send(software_revision_message(SOFTWARE_REVISION))  # §11

    def _source_address(self, command: J1939Command, fields: dict[str, int],
                        now: float) -> list[Frame]:
        self._store(command, fields)  # §16, J-3: in use at once
        self.address = self.settings["source_address"]
        if self._claimer is not None:
            return self._claimer.start(now, self.address)
        return []

    def _key_timing(self, command: J1939Command, fields: dict[str, int],
                    now: float) -> list[Frame]:
        self._store(command, fields)
        self._schedule_periodic(now)
        return []

    def _heartbeat(self, command: J1939Command, fields: dict[str, int],
                   now: float) -> list[Frame]:
        self._store(command, fields)
        self._schedule_heartbeat(now)
        return []

    def _demo_mode(self, command: J1939Command, fields: dict[str, int],
                   now: float) -> list[Frame]:
        self._store(command, fields)
        if not fields["on"]:
            self._demo = None  # §22: left by 00h
        return []

    def _switch_to_canopen(self, command: J1939Command, fields: dict[str, int],
                           now: float) -> list[Frame]:
        self.wants_canopen = True  # §27, J-1
        return []

    # -- keys and timers ------------------------------------------------------------------------

    def key_changed(self, key: int, down: bool, keys: int, now: float) -> list[Frame]:
        self._keys = keys
        self._now = now
        if down and self._demo is not None:
            self._demo.press(key, now)
        if not self._powered or not self.speaks or not self.settings["event_key_state"]:  # §17
            return []
        return self._send(key_message(key, down, self.settings["identifier"]))

    def _all_key_messages(self) -> list[Frame]:
        identifier = self.settings["identifier"]  # J-7: keys 1-12 in order, one frame each
        return [frame for key in range(1, _KEYS + 1)
                for frame in self._send(key_message(key, bool(self._keys >> (key - 1) & 1),
                                                    identifier))]

    def _schedule_heartbeat(self, now: float) -> None:
        on, period = self.settings["heartbeat"], self.settings["heartbeat_period"]
        self._heartbeat_timer.run(now, period * _UNIT if on and self._powered else 0)

    def _schedule_periodic(self, now: float) -> None:
        on, period = self.settings["periodic_key_state"], self.settings["key_message_period"]
        self._periodic_timer.run(now, period * _UNIT if on and self._powered else 0)

    def advance(self, now: float) -> list[Frame]:
        if not self._powered:
            return []
        self._now = now
        frames: list[Frame] = []
        if self._claimer is not None:
            self._claimer.advance(now)
        for _ in range(self._heartbeat_timer.fire(now)):  # one per period owed
            frames += self._send(heartbeat_message(self._heartbeat_counter, self._keys,
                                                   self.settings["identifier"]))
            self._heartbeat_counter = (self._heartbeat_counter + 1) & 0xFF  # J-6
        for _ in range(self._periodic_timer.fire(now)):
            frames += self._all_key_messages()
        if self._show is not None and self._show.finished(now):
            self._show = None
        return frames

    def deadlines(self) -> Iterable[float | None]:
        now = self._now
        return (
            self._heartbeat_timer.due,
            self._periodic_timer.due,
            self._claimer.deadline if self._claimer is not None else None,
            self._show.next_change(now) if self._show is not None else None,
            self._demo.next_change(now) if self._demo is not None else None,
        )

    def _send(self, data: bytes) -> list[Frame]:
        if self.silent:
            return []
        destination = self.settings["destination_address"]  # §14
        return [Frame(compose_id(PGN_COMMAND, self.address, destination, PRIORITY), data,
                      extended=True)]

    # -- what the keypad shows ------------------------------------------------------------------

    def displayed_leds(self, now: float) -> tuple[int, int]:
        return displayed_words(self._show, self._demo, self._words["led_on"],
                               self._words["led_blink"], now)

    def _commanded(self, key: int) -> dict[str, object]:
        """One key as commanded: colour and phases by their §7a names ("amber",
        "yellow/green"); blink_colour and alternate as CANopen mode's RGB picture (J-4), which
        "rgb" gives whole (on these LEDs amber is red + green)."""
        rgb = render_key(self._words["led_on"], self._words["led_blink"], key)
        look = self._looks.get(key, LedLook(LedState.OFF))
        phases = look_phases(look)
        return {**rgb, "colour": phases[0], "phases": list(phases)}

    def snapshot(self) -> dict[str, Any]:
        now = self._now
        on, blink = self.displayed_leds(now) if self._powered else (0, 0)
        shown_as_commanded = (on, blink) == (self._words["led_on"], self._words["led_blink"])
        keys = [{"key": key, "pressed": bool(self._keys >> (key - 1) & 1),
                 **(self._commanded(key) if shown_as_commanded else render_key(on, blink, key))}
                for key in range(1, _KEYS + 1)]
        colour = BacklightColour(self.settings["backlight_colour"])
        backlight: dict[str, object] = {"colour": colour.label,
                                        "level": self._live["backlight_level"]}
        indicator = self._live["led_brightness"]
        if self._demo is not None:
            demo_colour = self._demo.backlight_colour
            backlight = {"colour": demo_colour.label if demo_colour else "off",
                         "level": self._demo.level if demo_colour else 0}
            indicator = self._demo.level
        if not self._powered:
            backlight = {"colour": "off", "level": 0}
        show = None
        if self._show is not None and not self._show.finished(now):
            show = {"mode": SHOW_NAMES[self.settings["startup_led_show"]],
                    "step": self._show.step_index(now)}
        claim = self._claimer.state.value if self._claimer is not None else "off"
        return {
            "protocol": "j1939",
            "keys": keys,
            "indicator_brightness": indicator,
            "backlight": backlight,
            "startup_show": show,
            "demo": self._demo.describe() if self._demo is not None else None,
            "leds": dict(self._words),
            # what the host last commanded, apart from what a show or DEMO mode displays
            "commanded": [{**self._commanded(key),
                           "rgb": render_key(self._words["led_on"], self._words["led_blink"],
                                             key)}
                          for key in range(1, _KEYS + 1)],
            "j1939": {
                "source_address": self.address,
                "identifier": self.settings["identifier"],
                "destination_address": self.settings["destination_address"],
                "address_claim": claim,
                "name": self.name.to_bytes().hex(" ").upper(),
                "heartbeat_ms": round(self.settings["heartbeat_period"] * TIME_UNIT_S * 1000)
                if self.settings["heartbeat"] else 0,
                "periodic_key_state_ms": round(self.settings["key_message_period"]
                                               * TIME_UNIT_S * 1000)
                if self.settings["periodic_key_state"] else 0,
                "event_key_state": bool(self.settings["event_key_state"]),
                "led_acknowledge": bool(self.settings["led_acknowledge"]),
                "led_management": "single and multiple"
                if self.settings["led_management"] == 0x02 else "single",
            },
        }


__all__ = ["J1939Keypad"]
