"""The PKP-2600-SI keypad driver: key events, LEDs by colour, brightness, configuration.

The driver keeps the picture the application asked for and sends only what changed, at most
one LED-on and one LED-blink PDO per change (or per ``with keypad.batch():``). When the keypad
reboots it forgets its LEDs (errata.md, field reports), and generation 2 switches them off when
its watchdog trips (rev 1.5 §26): the driver starts it again and re-sends the whole picture as
it is when it is sent (the backlight colour goes by SDO, serialised with the application's own
backlight commands, so a restore never writes a colour the application has since changed).
In J1939 mode (``protocol="j1939"``, or after :meth:`Keypad.switch_to_j1939`) the same calls
go through :class:`~blinkcan.host.j1939_keypad.J1939KeypadLink`.

Every public method may be called from any thread: the picture (LEDs, brightness, the J1939
link) changes and is sent under one lock, so the last change sent is always the whole picture
as it is then; nothing blocking (no SDO, no wait for the bus thread) runs under it.
"""

from __future__ import annotations

import contextlib
import functools
import threading
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from typing import Any

import can

from blinkcan.devices.colours import BacklightColour, Channel, key_channels, led_colour
from blinkcan.devices.keypad import (
    LEVEL_MAX,
    MODEL,
    SHOW_COMPLETE,
    SHOW_FAST_FLASH,
    SHOW_OFF,
)
from blinkcan.devices.keypad_j1939 import BITRATES as J1939_BITRATES
from blinkcan.devices.keypad_j1939 import (
    DEFAULT_ADDRESS,
    DEFAULT_HOST_ADDRESS,
    PGN_COMMAND,
    PRIORITY,
    LedLook,
    led_look,
    look_channels,
)
from blinkcan.devices.keypad_j1939 import command as j1939_command
from blinkcan.devices.model import DeviceDescription
from blinkcan.devices.objects import Value
from blinkcan.devices.registry import identify
from blinkcan.devices.registry import model as registry_model
from blinkcan.host.bus import HostBus, Timer
from blinkcan.host.device import (
    BOOT_UP,
    Device,
    HealthEvent,
    NoDeviceError,
    WrongDeviceError,
    check_watchdog,
    confirm_or_close,
)
from blinkcan.host.events import EventSource
from blinkcan.host.j1939_keypad import HEARD, UNKNOWN, J1939KeypadLink, look_of
from blinkcan.host.registry import driver_class
from blinkcan.protocol.cob import check_node_id, check_range, check_time
from blinkcan.protocol.frame import Frame
from blinkcan.protocol.items import item_numbers
from blinkcan.protocol.j1939 import ADDRESS_MAX, j1939_frame
from blinkcan.protocol.nmt import NmtCommand, NmtState
from blinkcan.protocol.sdo_client import SdoAbortError, SdoTimeoutError

PRESS, RELEASE, LONG_PRESS = "press", "release", "long press"
#: NMT commands after which a keypad ignores PDOs until the next start (CiA 301: RPDOs are
#: acted on only in OPERATIONAL)
_PDOS_IGNORED_AFTER = (NmtCommand.STOP, NmtCommand.ENTER_PRE_OPERATIONAL)
SHOWS = {"off": SHOW_OFF, "complete": SHOW_COMPLETE, "fast flash": SHOW_FAST_FLASH}
#: PKP §44 / J1939 manual §27: the way back to CANopen, from the J1939 command table
J1939_RETURN = j1939_frame(PGN_COMMAND, DEFAULT_HOST_ADDRESS,
                           j1939_command("switch_to_canopen").encode(0),
                           destination=DEFAULT_ADDRESS, priority=PRIORITY)


@dataclass(frozen=True)
class KeyEvent:
    key: int
    action: str  # "press", "release" or "long press"
    time: float


def _masks(channels_by_key: Mapping[int, int]) -> dict[str, int]:
    """Per-colour key masks ({"red": ..., "green": ..., "blue": ...}) of a picture; the LED PDO
    layout in ``devices/`` places them in the frame (PKP §11)."""
    masks = {"red": 0, "green": 0, "blue": 0}
    for key, channels in channels_by_key.items():
        bit = 1 << (key - 1)
        for name, channel in (("red", Channel.RED), ("green", Channel.GREEN),
                              ("blue", Channel.BLUE)):
            if channels & channel:
                masks[name] |= bit
    return masks


def _check_link(protocol: str, address: int, host_node_id: int) -> None:
    """The protocol, the J1939 address (in J1939 mode) and the host's node id of a keypad
    driver: TypeError/ValueError naming the valid values."""
    if protocol not in ("canopen", "j1939"):
        raise ValueError(f"protocol must be canopen or j1939, not {protocol!r}")
    if protocol == "j1939":
        check_range("J1939 keypad address", address, 1, ADDRESS_MAX, hexadecimal=True)
    check_node_id(host_node_id)


class Keypad(Device):
    """Drive a keypad at ``node_id`` on ``bus`` (a python-can bus or a :class:`HostBus`): the
    PKP-2600-SI, or the registered model ``model`` names (its driver class is built).

    ``start``: send NMT start now, after every boot-up and after a watchdog trip.
    ``long_press``: seconds a key is held before a "long press" event. ``restore``: re-send the
    LED picture after a boot-up or a watchdog trip. ``verify``: confirm that this model answers
    at ``node_id`` first (False only for a keypad that cannot answer SDO).
    ``protocol="j1939"`` drives a keypad in J1939 mode at ``address`` (spec/pkp-2600-si-j1939.md):
    ``verify`` then asks for its software revision and address claim (§11, §20) and raises
    :class:`NoDeviceError` ("no keypad heard at 21h") when nothing answers. The driver follows
    the keypad by its NAME when a claim moves it (J-5), raises
    :class:`~blinkcan.host.j1939_keypad.KeypadGoneError` rather than command the node that took
    its address, and restores the LEDs when its claim or heartbeat says it powered on.
    """

    # the model's description carries its keys, LED layout and PDOs; ``model=`` names
    # another registered keypad, whose driver class (a subclass) is built instead
    def __new__(cls, *args: Any, model: str | None = None, **kwargs: Any) -> Keypad:
        target: type[Keypad] = cls
        if model is not None and model != MODEL:
            found = driver_class(model)
            if not issubclass(found, Keypad):
                raise ValueError(f"{model!r} is not a keypad")
            target = found
        return super().__new__(target)

    @classmethod
    def connect(cls, bus: HostBus | can.BusABC, node_id: int = 0x15, **options: Any) -> Keypad:
        """The driver of whichever keypad answers at ``node_id``: its 100Bh model id names the
        model (two models share 1000h, MT M59). :class:`WrongDeviceError` for a device that is
        no keypad, :class:`NoDeviceError` when nothing answers. A keypad in J1939 mode
        (``protocol="j1939"``, ``address=``) answers no SDO and tells no model id (§11: its
        software revision): the driver of the model with a J1939 mode confirms it as usual."""
        if options.get("protocol", "canopen") != "canopen":
            return cls(bus, node_id, **options)
        for time_option in ("sdo_timeout", "long_press"):  # bad ones: before the read
            if time_option in options:
                check_time(time_option, options[time_option], 0)
        host = HostBus.attach(bus)
        try:
            raw = host.sdo(check_node_id(node_id), options.get("sdo_timeout", 0.5), 1).upload(
                0x100B, 0)
        except SdoTimeoutError as error:
            raise NoDeviceError(f"no device answers at node {node_id:02X}h ({error})") from None
        except SdoAbortError as error:
            raise WrongDeviceError(f"node {node_id:02X}h has no model id (100Bh): not a "
                                   f"keypad ({error})") from None
        finally:
            host.release()
        model_id = raw.decode("ascii", "replace")
        found = identify(model_id=model_id)
        # a keypad is a model whose driver is this class or one built on it (the registry's)
        if found is None or not issubclass(driver_class(found.model), cls):
            what = found.title if found is not None else f"{model_id!r}"
            raise WrongDeviceError(f"node {node_id:02X}h is a {what}, not a keypad")
        return cls(bus, node_id, model=found.model, **options)

    def __init__(self, bus: HostBus | can.BusABC, node_id: int = 0x15, *, start: bool = True,
                 long_press: float = 0.8, restore: bool = True, generation: str | None = None,
                 watchdog: float | None = None, host_node_id: int = 0x7F,
                 sdo_timeout: float = 0.5, verify: bool = True, model: str | None = None,
                 protocol: str = "canopen", address: int = DEFAULT_ADDRESS) -> None:
        _check_link(protocol, address, host_node_id)  # before the bus is attached
        #: True from an NMT stop or pre-operational (or such a state reported) to the next
        #: start: the LED PDOs sent meanwhile were ignored, the picture goes again after it
        #: (set before the bus handlers that change it are subscribed)
        self._pdos_ignored = not start
        self._missed = False  # a picture PDO went while they were ignored
        #: the registered model this driver runs (the PKP-2600-SI unless ``model`` names one)
        self._model = registry_model(model or MODEL)
        self._model_given = model is not None
        if watchdog is not None:  # checked before anything is sent (the identity reads)
            check_watchdog(watchdog)
        check_time("long_press", long_press, 0)
        super().__init__(bus, node_id, self._describe(generation, node_id),
                         sdo_timeout=sdo_timeout)
        self._generation = generation
        self.host_node_id = host_node_id
        self.keys = EventSource[KeyEvent](self.host.scheduler)
        self.long_press = long_press
        self.auto_start = start
        self.restore = restore
        self.pressed: frozenset[int] = frozenset()
        self._long_timers: dict[int, Timer] = {}
        self._steady: dict[int, int] = {}  # key -> channels lit steadily / in phase A
        self._blink: dict[int, int] = {}  # key -> channels that blink
        #: key -> the §7a look commanded in J1939 mode (its colour, e.g. amber, kept as named)
        self._looks: dict[int, LedLook] = {}
        self._sent: tuple[Frame, Frame] | None = None
        self._batching = 0
        self._force_pending = False  # a forced re-send asked for during a batch
        #: the picture (LEDs, brightness, the J1939 link): changed and sent under it, by the
        #: application's threads and the bus thread's restores alike
        self._picture_lock = threading.RLock()
        #: held while a backlight command is sent and the driver's picture updated, and while
        #: a restore computes what to send and sends it: the two never interleave
        self._command_lock = threading.Lock()
        self._generation_lock = threading.Lock()
        self._indicator: int | None = None
        self._backlight_level: int | None = None
        self._backlight_colour: int | None = None
        key_pdo = self.description.pdo("key_state")
        self.listen(key_pdo.cob_id(node_id), self._on_keys)
        #: the J1939 side while the keypad is in J1939 mode, else None
        self.j1939: J1939KeypadLink | None = None
        if protocol == "j1939":
            if "j1939" not in self.description.features:
                self.close()
                raise ValueError(f"the {self.description.title} has no J1939 mode")
            self._use_j1939(address)
            if verify:  # J1939 commands are unacknowledged: hear the keypad first
                self._confirm_j1939(sdo_timeout)
            self.confirmed = True
        else:
            confirm_or_close(self, verify)
            if verify:  # known from now on: no property reads the device later
                self._detect_or_close()
        if watchdog is not None:
            self.watch_host(watchdog)
        if start and self.j1939 is None:
            self.start()

    # -- firmware generation --------------------------------------------------------------------

    @property
    def generation(self) -> str | None:
        """"1.1" or "1.5": given, or found when the driver confirmed the device (the LED
        objects and the backlight PDO differ). None while unknown (``verify=False`` and no
        generation given): this property never reads the device; :meth:`detect_generation`
        does."""
        return self._generation

    def detect_generation(self) -> str:
        """Find the generation by probing 1016h, which only generation 2 has
        (pkp-rev1.1-vs-rev1.5.md): one SDO read, the first time only."""
        if self._generation is None:
            with self._generation_lock:
                if self._generation is None:
                    found = self._probe_generation()
                    self.description = self._describe(found, self.node_id)
                    self._generation = found
        return self._generation

    def _detect_or_close(self) -> None:
        try:
            self.detect_generation()
        except BaseException:
            self.close()
            raise

    def adopt_identity(self, found: Mapping[str, Value | None]) -> None:
        """No model named: a keypad this very class runs (its 100Bh says which) is adopted, as
        :meth:`connect` would; any other device is then refused by the comparison."""
        model_id = found["model_id"]
        answered = identify(model_id=model_id) if isinstance(model_id, str) else None
        if (not self._model_given and answered is not None
                and answered.model != self._model.name
                and driver_class(answered.model) is type(self)):
            self._model = registry_model(answered.model)
            if self._generation not in self._model.generations:
                self._generation = None  # a generation of the model first assumed
            self.description = self._describe(self._generation, self.node_id)

    def _probe_generation(self) -> str:
        """The model's generation with 1016h if the device answers 1016h, else the one
        without (pkp-rev1.1-vs-rev1.5.md); a model of one generation is not probed."""
        generations = self._model.generations
        if len(generations) == 1:
            return generations[0]
        try:
            self.sdo.upload(0x1016, 0)
            heard = True
        except SdoAbortError:
            heard = False
        return next(g for g in generations
                    if (self._model.description(g).consumer_heartbeat is not None) == heard)

    def _describe(self, generation: str | None, node_id: int) -> DeviceDescription:
        """This driver's model at ``generation`` (None: the first), CiA 301 profile."""
        return self._model.description(generation, "cia301", node_id)

    def watch_host(self, period: float) -> None:
        """Generation 2 only: the keypad switches its LEDs off when the controller's
        heartbeat stops (rev 1.5 §26)."""
        self.detect_generation()  # the description of the generation found
        if self.description.consumer_heartbeat is None:
            raise ValueError(f"this {self.description.title} ({self.description.edition}) "
                             "has no consumer heartbeat (1016h)")
        super().watch_host(period)

    def set_consumer_heartbeat(self, node_id: int, period: float) -> None:
        self.detect_generation()  # 1016h is generation 2's: find out which this is
        super().set_consumer_heartbeat(node_id, period)

    def set_synchronous(self, leds: bool = True, key_state_every: int | None = 1) -> None:
        """Generation 2: LED PDOs applied at the next SYNC and the key state sent every n-th
        SYNC (rev 1.5 §36/§37/§44a); run a SYNC producer (``host.produce_sync``). With
        ``leds=False`` and ``key_state_every=None`` the keypad is event-driven again."""
        self.detect_generation()  # the description of the generation found
        if "sync" not in self.description.features:  # errata G3
            raise ValueError(f"this {self.description.title} ({self.description.edition}) "
                             "has no synchronous PDOs")
        led_type = 0x00 if leds else 0xFE
        self.write("rpdo1_transmission_type", led_type)
        self.write("rpdo2_transmission_type", led_type)
        self.write("tpdo1_transmission_type", key_state_every or 0xFE)

    # -- keys -------------------------------------------------------------------------------------

    def on_key(self, callback: Callable[[KeyEvent], object]) -> Callable[[], None]:
        """Call ``callback(event)`` on the bus thread for every key event; returns the remover."""
        return self.keys.subscribe(callback)

    def events(self, timeout: float | None = None) -> Iterator[KeyEvent]:
        """Key events from now on, in this thread; stops after ``timeout`` s without one."""
        return self.keys.iterate(timeout)

    def _on_keys(self, frame: Frame, now: float) -> None:
        layout = self.description.pdo("key_state")
        if len(frame.data) < layout.min_length:  # errata P8: accept DLC >= 2
            return
        mask = layout.decode(frame.data)["keys"] & ((1 << self.description.face.keys) - 1)
        self._keys_now(frozenset(item_numbers(mask)), now)

    def _on_j1939_key(self, key: int, pressed: bool, now: float) -> None:
        self._keys_now(self.pressed | {key} if pressed else self.pressed - {key}, now)

    def _keys_now(self, pressed: frozenset[int], now: float) -> None:
        before, self.pressed = self.pressed, pressed
        for key in sorted(pressed - before):
            self.keys.emit(KeyEvent(key, PRESS, now))
            self._long_timers[key] = self.host.call_later(
                self.long_press, functools.partial(self._long, key))
        for key in sorted(before - pressed):
            timer = self._long_timers.pop(key, None)
            if timer is not None:
                timer.cancel()
            self.keys.emit(KeyEvent(key, RELEASE, now))

    def _long(self, key: int) -> None:
        if self._long_timers.pop(key, None) is not None and key in self.pressed:
            self.keys.emit(KeyEvent(key, LONG_PRESS, self.host.clock()))

    # -- LEDs -------------------------------------------------------------------------------------

    def set_led(self, key: int, colour: str = "off", blink: str | None = None) -> None:
        """Light ``key`` (1..12) in ``colour``. ``blink`` makes it blink: the same colour (or
        ``colour="off"``) blinks on and off, another colour alternates with ``colour``
        (PKP §12 alternate mode)::

            set_led(3, "blue")                  # steady blue
            set_led(3, "blue", blink="blue")    # blue, blinking
            set_led(3, "red", blink="green")    # red and green alternating

        Colours: off, red, green, blue, yellow/amber, cyan, magenta, white; in J1939 mode
        the §7a codes, where amber (orange) and yellow/green are colours of their own.
        """
        face = self.description.face
        check_range("key", key, 1, face.keys)
        if key not in face.led_keys:
            raise ValueError(f"key {key} has no LED; keys with one: "
                             f"{', '.join(map(str, face.led_keys))}")
        if self.j1939 is not None:  # §7a colour codes: amber and yellow/green are their own
            look = led_look(colour, blink)
            on, toggled_channels = look_channels(look)
            with self._picture_lock:
                self._steady[key], self._blink[key] = int(on), int(toggled_channels)
                self._looks[key] = look
                self._send_changes()
            return
        steady = led_colour(colour)
        blinking = led_colour(blink) if blink is not None else Channel.NONE
        # the twin's phase model: phase A shows the "on" channels, phase B the on-and-not-
        # blinking plus the blinking-and-not-on ones; so one colour blinks with on = blink =
        # colour, and two alternate with on = colour, blink = colour ^ other.
        if blink is None:
            toggled = 0
        elif blinking == steady:
            toggled = int(steady)
        else:
            toggled = int(steady ^ blinking)
        with self._picture_lock:
            self._steady[key] = int(steady)
            self._blink[key] = toggled
            self._looks.pop(key, None)
            self._send_changes()

    def read_leds(self) -> None:
        """Take the LEDs the keypad shows now (2001h/2002h, PKP §11) as this driver's picture,
        so that the next change sends only itself: a program that starts against a keypad
        lit by someone else changes one key, not all (six SDO reads)."""
        width = self.description.pdo("led_on").signal("red").length
        words = []
        for index in (0x2001, 0x2002):  # LED on, LED blink: fields of one word each
            word = 0
            for field in self.description.led_fields:
                value = int.from_bytes(self.sdo.upload(index, field.subindex), "little")
                word |= (value & ((1 << field.width) - 1)) << field.shift
            words.append(word)
        on, blink = words
        keys = range(1, self.description.face.keys + 1)
        steady = {key: key_channels(on, key, width) for key in keys}
        blinking = {key: key_channels(blink, key, width) for key in keys}

        with self._picture_lock:
            self._steady = {key: channels for key, channels in steady.items() if channels}
            self._blink = {key: channels for key, channels in blinking.items() if channels}
            self._looks = {}
            self._sent = (self.pdo_frame("led_on", _masks(self._steady)),
                          self.pdo_frame("led_blink", _masks(self._blink)))

    def set_leds(self, colours: Mapping[int, str], blink: Mapping[int, str] | None = None) -> None:
        """Several keys at once, in at most two PDOs."""
        with self.batch():
            for key in set(colours) | set(blink or {}):
                self.set_led(key, colours.get(key, "off"), (blink or {}).get(key))

    def clear_leds(self) -> None:
        with self.batch():
            for key in self.description.face.led_keys:
                self.set_led(key, "off")

    @contextlib.contextmanager
    def batch(self) -> Iterator[None]:
        """LED changes inside are sent together when the block ends (changes other threads
        make meanwhile go with them)."""
        with self._picture_lock:
            self._batching += 1
        try:
            yield
        finally:
            with self._picture_lock:
                self._batching -= 1
                self._send_changes()

    def _send_changes(self, force: bool = False) -> None:
        """Send what changed in the picture (everything with ``force``); under the picture
        lock, so what is sent last is the picture as it is then."""
        with self._picture_lock:
            if self._batching:
                self._force_pending |= force  # e.g. a reboot during a batch: all at its end
                return
            force, self._force_pending = force or self._force_pending, False
            self._send_picture(force)

    def _send_picture(self, force: bool) -> None:
        if self.j1939 is not None:  # §7a: one command per key the application named
            named = set(self._steady) | set(self._blink)
            self.j1939.show({key: self._looks.get(key) or look_of(self._steady.get(key, 0),
                                                                  self._blink.get(key, 0))
                             for key in named}, force)
            return
        on, blink = self.pdo_frame("led_on", _masks(self._steady)), \
            self.pdo_frame("led_blink", _masks(self._blink))
        sent = self._sent
        if force or sent is None or sent[0] != on:
            self.send_shown(on)
        if force or sent is None or sent[1] != blink:
            self.send_shown(blink)
        self._sent = (on, blink)

    # -- brightness and backlight -----------------------------------------------------------------

    def set_brightness(self, level: int) -> None:
        """Indicator LED brightness 0..63 (PKP §13; 0 is the minimum, not off)."""
        check_range("brightness", level, 0, LEVEL_MAX)
        with self._picture_lock:
            self._indicator = level
            if self.j1939 is not None:
                self.j1939.send("led_brightness", level)
                return
            self.send_shown(self.pdo_frame("indicator_brightness", {"level": level}))

    def set_backlight(self, colour: str | None = None, level: int | None = None) -> None:
        """Backlight colour (by name, PKP §18c) and level 0..63 (0 = off, PKP §14)."""
        code = BacklightColour.from_name(colour) if colour is not None else None
        if level is not None:
            check_range("backlight level", level, 0, LEVEL_MAX)
        with self._command_lock:
            if code is not None:
                self.write("backlight_colour", int(code))
                self._backlight_colour = int(code)
            if level is not None:
                with self._picture_lock:
                    self._backlight_level = level
                    if self.j1939 is not None:
                        self.j1939.send("backlight_level", level)
                    else:
                        self.send_shown(self._backlight_frame(level))

    def _restore_backlight(self) -> None:
        """The backlight as it is when this runs (after any backlight command in flight)."""
        with self._command_lock:
            if self._backlight_colour is not None:
                self.write("backlight_colour", self._backlight_colour)
            with self._picture_lock:
                if self._backlight_level is not None:
                    self.send_shown(self._backlight_frame(self._backlight_level))

    def _backlight_frame(self, level: int) -> Frame:
        # rev 1.5 §15: generation 2 reads byte 1 as the colour (00h = the default colour), so
        # a rev 1.1-style frame would undo a colour set before; send the colour along.
        self.detect_generation()  # the description of the generation found
        colour = ((self._backlight_colour or 0)
                  if "backlight-colour-pdo" in self.description.features else 0)
        return self.pdo_frame("backlight_brightness", {"level": level, "colour": colour})

    def set_default_backlight_colour(self, colour: str) -> None:
        self.write("default_backlight_colour", int(BacklightColour.from_name(colour)))

    def set_startup_levels(self, brightness: int | None = None, backlight: int | None = None
                           ) -> None:
        """Levels applied at power-on (2003h/05, /06)."""
        if brightness is not None:
            self.write("startup_indicator_brightness", brightness)
        if backlight is not None:
            self.write("startup_backlight_brightness", backlight)

    # -- configuration ----------------------------------------------------------------------------

    def set_startup_show(self, show: str) -> None:
        """"complete", "fast flash" or "off" (PKP §23)."""
        if show not in SHOWS:
            raise ValueError(f"startup show must be one of {', '.join(SHOWS)}, not {show!r}")
        self.write("startup_led_show", SHOWS[show])

    def set_demo_mode(self, enabled: bool) -> None:
        """DEMO mode starts at the next power-on (PKP §24)."""
        self.write("demo_mode", int(enabled))

    def set_periodic_key_state(self, period: float) -> None:
        """Send the key state every ``period`` s as well as on change; 0 = only on change."""
        self.write_period("tpdo1_event_timer", "key state period", period)

    def read(self, name: str) -> Value:
        """An object by its CANopen name (SDO); refused in J1939 mode, which has no SDO."""
        if self.j1939 is not None:  # spec/pkp-2600-si-j1939.md: the keypad answers no SDO
            raise ValueError(f"{name} cannot be read in J1939 mode: the keypad answers no SDO "
                             "there (spec/pkp-2600-si-j1939.md); identity() gives what it "
                             "reports")
        return super().read(name)

    def write(self, name: str, value: Value) -> None:
        """A setting by its CANopen name; in J1939 mode sent as the J1939 command for it."""
        if self.j1939 is None:
            super().write(name, value)
            return
        self.check(name, value)
        self.j1939.write(name, int(value))

    @property
    def protocol(self) -> str:
        return "canopen" if self.j1939 is None else "j1939"

    def switch_to_j1939(self, *, confirm: bool = False, address: int = DEFAULT_ADDRESS) -> None:
        """The keypad leaves CANopen (PKP §44) and restarts in J1939 mode at ``address`` (21h
        unless a J1939 source address was stored before, J-1); this driver goes on over J1939
        and sends the LED picture again. :meth:`switch_to_canopen` brings both back."""
        if not confirm:
            raise ValueError("the keypad will stop speaking CANopen: pass confirm=True")
        self.write("can_protocol", 1)
        with self._picture_lock:
            self._use_j1939(address)
        if self.restore:
            self._restore_j1939()

    def switch_to_canopen(self) -> None:
        """The documented way back from J1939 (§27, PKP §44), to CANopen factory settings; the
        keypad's boot-up then restarts it and the driver re-sends the picture over CANopen."""
        with self._picture_lock:
            if self.j1939 is None:
                self.host.send(J1939_RETURN)
                return
            self.j1939.send("switch_to_canopen", 0)
            self.j1939.close()
            self.j1939 = None
            self._sent = None

    def _use_j1939(self, address: int) -> None:
        self.j1939 = J1939KeypadLink(self.host, address, self._on_j1939_key,
                                     on_health=self._on_j1939_health)
        self.on_close(self.j1939.close)

    def _confirm_j1939(self, timeout: float) -> None:
        assert self.j1939 is not None
        try:
            self.j1939.confirm(timeout)
        except BaseException:
            self.close()
            raise

    def _on_j1939_health(self, kind: str, address: int, now: float) -> None:
        """What the J1939 link heard (on the bus thread), as the health events CANopen mode
        has: "lost"/"back" from the heartbeat (§18), "boot-up" (power-on: the LEDs are
        restored), "address lost" and "moved" (§20, J-5)."""
        if kind == HEARD:
            self.heard(now)  # "back" names the address (health_id)
            return
        if kind == UNKNOWN:  # §18: it may have powered on unseen; sending again is harmless
            if self.restore and self.confirmed:
                self.host.spawn(self._restore_j1939)
            return
        self.health.emit(HealthEvent(address, kind, now))
        if kind == BOOT_UP:
            for timer in self._long_timers.values():
                timer.cancel()
            self._long_timers.clear()
            self.pressed = frozenset()
            if self.j1939 is not None:
                self.j1939.forget_looks()  # it powers on with its LEDs off
            if self.restore and self.confirmed:
                self.host.spawn(self._restore_j1939)

    @property
    def health_id(self) -> int:
        """The node id; in J1939 mode the keypad's address (what "lost" and "back" name)."""
        return self.node_id if self.j1939 is None else self.j1939.address

    def identity(self) -> Any:
        """The CANopen :class:`Identity` (1000h, 1018h, 100Bh, ...) or, in J1939 mode, a
        :class:`J1939Identity`: what the keypad tells over J1939, software revision (§11),
        NAME and claim (§20), heartbeat (§18). (Typed Any: which one depends on the protocol
        the keypad speaks now.)"""
        if self.j1939 is not None:
            return self.j1939.identity(self.description.model, self.sdo.timeout)
        return super().identity()

    def set_node_id(self, node_id: int, *, confirm: bool = False) -> None:
        """Store a new node id (Device.set_node_id); in J1939 mode the keypad's source address
        instead (§16, 70h: 01h-FDh, in use at once, J-3; its identifier kept), refused when a
        keypad answers at the new address, and this driver follows the keypad there."""
        if self.j1939 is None:
            super().set_node_id(node_id, confirm=confirm)
            return
        address = next(f for f in j1939_command("source_address").fields if f.name == "address")
        if not address.accepts(node_id):
            raise ValueError(f"a J1939 source address is {address.valid}, not {node_id:#04x}")
        if not confirm:
            raise ValueError("changing the source address moves the keypad on the bus at once: "
                             "pass confirm=True")
        if node_id == self.j1939.address:
            return
        probe = J1939KeypadLink(self.host, node_id, lambda key, pressed, now: None)
        try:
            probe.software_revision(0.2)
        except TimeoutError:
            pass  # nobody answers there: free
        else:
            raise ValueError(f"J1939 address {node_id:02X}h is taken: a keypad answers there")
        finally:
            probe.close()
        self.j1939.send("source_address", node_id, 0xFF)  # FFh: the identifier unchanged
        self.j1939.address = node_id
        try:  # §16: in use at once, so the keypad answers there (never a move not seen)
            self.j1939.software_revision(self.sdo.timeout)
        except TimeoutError:
            raise NoDeviceError(f"no keypad answers at {node_id:02X}h after the move to it "
                                "(§16, 70h): the keypad is gone or did not take it") from None

    def set_bitrate(self, bitrate: int, *, confirm: bool = False) -> None:
        """Store a bit rate (Device.set_bitrate); in J1939 mode with the §15 codes (6Fh: 500 or
        250 kbit/s), in use at the next power-on (J-3)."""
        if self.j1939 is None:
            super().set_bitrate(bitrate, confirm=confirm)
            return
        codes = {rate: code for code, rate in J1939_BITRATES.items()}
        if bitrate not in codes:
            raise ValueError(f"in J1939 mode the keypad runs at "
                             f"{', '.join(map(str, sorted(codes)))} bit/s, not {bitrate}")
        if not confirm:
            raise ValueError("changing the bit rate takes the device off this bus at its next "
                             "power-on: pass confirm=True")
        self.j1939.send("baud_rate", codes[bitrate])

    def _restore_j1939(self) -> None:
        with self._picture_lock:
            self._send_changes(force=True)
            if self._indicator is not None:
                self.set_brightness(self._indicator)
        # outside the picture lock: set_backlight takes the command lock first
        if self._backlight_colour is not None or self._backlight_level is not None:
            colour = self._backlight_colour
            self.set_backlight(BacklightColour(colour).label if colour else None,
                               self._backlight_level)

    # -- recovery ---------------------------------------------------------------------------------

    def nmt_command_seen(self, command: NmtCommand) -> None:
        if command in _PDOS_IGNORED_AFTER:  # CiA 301: RPDOs only in OPERATIONAL
            self._pdos_ignored = True

    def state_reported(self, state: NmtState, now: float) -> None:
        if state is not NmtState.OPERATIONAL:
            self._pdos_ignored = True
        else:  # started by a command this driver did not hear (its own were): show it all
            self.nmt_command_sent(NmtCommand.START)

    def nmt_command_sent(self, command: NmtCommand) -> None:
        """After a start, the picture is sent again if part of it went while the keypad
        was stopped or pre-operational (it dropped those PDOs), as after a reboot; a picture
        this driver never sent is not (it would switch off what others lit)."""
        if command is NmtCommand.START and self._pdos_ignored:
            missed, self._pdos_ignored, self._missed = self._missed, False, False
            if missed and self.restore and self.confirmed:
                self.send_picture_again(leds_unsent=False)

    def send_shown(self, frame: Frame) -> None:
        """Send a PDO of the picture (LEDs, levels, rings), noting one the keypad ignores."""
        self.host.send(frame)
        if self._pdos_ignored:
            self._missed = True

    def booted_up(self, now: float) -> None:
        for timer in self._long_timers.values():
            timer.cancel()
        self._long_timers.clear()
        self.pressed = frozenset()
        self._recover()

    def watchdog_tripped(self, now: float) -> None:
        self._recover()  # rev 1.5 §26 note 2: the keypad switched its LEDs off

    def _recover(self) -> None:
        # the start below, else the application's, after which what went meanwhile goes again
        self._pdos_ignored, self._missed = not self.auto_start, False
        if self.auto_start:
            self.start()
        with self._picture_lock:
            if not self.restore:
                self._sent = None
                return
        self.send_picture_again()

    def send_picture_again(self, leds_unsent: bool = True) -> None:
        """Send the whole picture the keypad lost or ignored: LEDs (also while this driver
        has sent none, with ``leds_unsent``: all off), indicator brightness, backlight (its
        colour by SDO, in a worker). A driver with more to show (ring LEDs) extends it."""
        with self._picture_lock:
            if leds_unsent or self._sent is not None:
                self._send_changes(force=True)  # errata field report: a rebooted keypad forgot
            if self._indicator is not None:
                self.send_shown(self.pdo_frame("indicator_brightness",
                                               {"level": self._indicator}))
            if self._backlight_colour is not None:
                self.host.spawn(self._restore_backlight)  # the colour goes by SDO: off here
            elif self._backlight_level is not None:
                self.send_shown(self._backlight_frame(self._backlight_level))
