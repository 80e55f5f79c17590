"""The PKP-2600-SI keypad twin: manual rev 1.1 by default, ``manual="1.5"`` for the newer
firmware (rev 1.5, V2.8), as a small delta (pkp-rev1.1-vs-rev1.5.md, errata G1-G6).

On top of :class:`CanopenTwin`: the key-state TPDO with its tick timer, the LED picture with
2001h/2002h as views of it (their sub-index layout differs by generation), brightness and
backlight, the startup LED show, DEMO mode, the switch to J1939 and back; generation 2 adds
SYNC (held RPDOs, cyclic TPDO), the backlight colour in the PDO, the node id in use at once,
and, from the base, the consumer heartbeat and restore defaults. In J1939 mode
(spec/pkp-2600-si-j1939.md) the keypad is :class:`~blinkcan.twin.keypad_j1939.J1939Keypad`.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from functools import cache
from types import MappingProxyType
from typing import Any

from blinkcan.devices.colours import BacklightColour
from blinkcan.devices.keypad import (
    LEVEL_MAX,
    MODEL,
    PROTOCOL_CANOPEN,
    PROTOCOL_J1939,
    TICK_PERIOD_S,
)
from blinkcan.devices.keypad_j1939 import DEFAULT_NAME, NVM_PREFIX, STORED_SETTINGS
from blinkcan.devices.model import LedField, Quirks
from blinkcan.devices.objects import Value
from blinkcan.devices.registry import load_class
from blinkcan.devices.registry import model as registered_model
from blinkcan.protocol.cob import NMT, SYNC, check_range, check_time
from blinkcan.protocol.frame import Frame
from blinkcan.protocol.items import item_numbers
from blinkcan.protocol.j1939 import J1939Name
from blinkcan.protocol.nmt import NmtState, parse_nmt
from blinkcan.twin.base import CanopenTwin
from blinkcan.twin.keypad_display import (
    BLINK_PERIOD_S,
    SHOW_NAMES,
    DemoMode,
    ShowPlayer,
    displayed_words,
    fill,
    render_key,
    startup_shows,
)
from blinkcan.twin.keypad_j1939 import J1939Keypad
from blinkcan.twin.nvm import NvmArgument, open_nvm
from blinkcan.twin.schedule import milliseconds

PROTOCOLS = {"canopen": PROTOCOL_CANOPEN, "j1939": PROTOCOL_J1939}


def _split_settings(settings: Mapping[str, Value]) -> tuple[dict[str, Value], dict[str, int]]:
    """``settings`` by object name, and the J1939 stored settings among them by their
    ``j1939_`` name (``j1939_source_address``: §16 70h, 01h-FDh), checked against the range
    their command accepts."""
    canopen: dict[str, Value] = {}
    j1939: dict[str, int] = {}
    for name, value in settings.items():
        if not name.startswith(NVM_PREFIX):
            canopen[name] = value
            continue
        setting = STORED_SETTINGS.get(name[len(NVM_PREFIX):])
        if setting is None:
            raise ValueError(f"{name!r} is not a stored J1939 setting; they are "
                             f"{', '.join(NVM_PREFIX + key for key in sorted(STORED_SETTINGS))}")
        if not isinstance(value, int) or isinstance(value, bool) or value not in setting.valid:
            raise ValueError(f"{name} takes {setting.valid}, not {value!r}")
        j1939[name[len(NVM_PREFIX):]] = value
    return canopen, j1939


@cache
def _led_views(prefixes: tuple[str, ...], fields: tuple[LedField, ...]
               ) -> Mapping[str, tuple[str, int, int]]:
    """2001h/2002h sub-indices as views of the LED words: name -> (word, shift, mask); once
    per model (a pure function of the description's fields)."""
    return MappingProxyType({f"{prefix}_{f.suffix}": (prefix, f.shift, (1 << f.width) - 1)
                             for prefix in prefixes for f in fields})


class KeypadTwin(CanopenTwin):
    """A PKP-2600-SI that behaves on the bus as the manual describes.

    ``node_id`` is the unit's factory node id; ``nvm`` a path to keep its stored settings in
    (or None for memory). ``manual`` selects the firmware generation ("1.1" or "1.5").
    ``protocol`` ("canopen" or "j1939") is the factory protocol, used while the NVM holds
    none (a stored protocol wins, as a stored node id does); ``name`` is the J1939 NAME it
    claims its address with (J-5). ``model`` names another registered keypad, whose twin
    class (a subclass) is built instead.
    """

    #: the model this class runs when ``model`` names none (a subclass names its own)
    MODEL: str = MODEL

    def __new__(cls, *args: Any, model: str | None = None, **kwargs: Any) -> KeypadTwin:
        """``KeypadTwin(model="pkp-3500-mt")`` builds the twin class the registry names."""
        target: type[KeypadTwin] = cls
        if model is not None:
            found = load_class(registered_model(model).twin, CanopenTwin)
            if not issubclass(found, KeypadTwin):
                raise ValueError(f"{model!r} is not a keypad")
            if issubclass(found, cls):  # else __init__ says this class does not run it
                target = found
        return super().__new__(target)

    def __init__(
        self,
        node_id: int = 0x15,
        quirks: Quirks = "firmware",
        nvm: NvmArgument = None,
        manual: str | None = None,
        protocol: str = "canopen",
        name: J1939Name | bytes = DEFAULT_NAME,
        settings: Mapping[str, Value] | None = None,
        model: str | None = None,
    ) -> None:
        # the registry describes the model (its first generation unless ``manual`` names one)
        found = registered_model(model or self.MODEL)
        runs_on = load_class(found.twin, CanopenTwin)
        own = load_class(registered_model(self.MODEL).twin, CanopenTwin)
        if not (isinstance(self, runs_on) and issubclass(runs_on, own)):  # a subclass may run it
            raise ValueError(f"{found.name} runs on {found.twin}, not {type(self).__name__}")
        if manual is not None and manual not in found.generations:
            raise ValueError(f"the {found.name} manual must be one of "
                             f"{', '.join(found.generations)}, not {manual!r}")
        description = found.description(manual, quirks, node_id)
        if protocol not in PROTOCOLS:
            raise ValueError(f"protocol must be one of {', '.join(PROTOCOLS)}, not {protocol!r}")
        nvm = open_nvm(nvm, description,  # J1939 settings live in the same store
                       {NVM_PREFIX + key: f.valid for key, f in STORED_SETTINGS.items()})
        j1939_name = name if isinstance(name, J1939Name) else J1939Name.from_bytes(name)
        speaks = "j1939" in description.features
        if protocol == "j1939" and not speaks:
            raise ValueError(f"the {description.model} has no documented J1939 mode")
        self._j1939_keypad = J1939Keypad(j1939_name, {}, self._save_j1939, speaks)
        canopen_settings, j1939_settings = _split_settings(settings or {})
        fresh = nvm.load() is None  # a corrupt or foreign file fails here
        super().__init__(description, node_id, nvm, canopen_settings,
                         self._j1939_settings_to_store)
        self._j1939_keypad.settings.update(self._stored_j1939_settings(self.stored_settings()))
        if j1939_settings:  # as if written earlier by their J1939 commands, like ``settings``
            self._j1939_keypad.settings.update(j1939_settings)
            self.save_settings(self._j1939_settings_to_store())
        store = self.objects
        if protocol == "j1939" and fresh:
            store.set("can_protocol", PROTOCOL_J1939)
            self.save_settings()
        self._face = description.face
        self._key_pdo = description.pdo("key_state")
        self._tick_width = self._key_pdo.signal("tick").length  # bits: PKP §11, errata P8
        self._keys = 0
        self._show: ShowPlayer | None = None
        self._show_mode = 0
        self._demo: DemoMode | None = None
        self._make_demo: Callable[[float], DemoMode] = DemoMode
        self._j1939 = False
        #: errata G3: SYNC-driven LED RPDOs and key-state TPDO (rev 1.5 §10, PKP-3500-MT)
        self._synchronous = "sync" in description.features
        #: the LED picture (PKP §11 word: red 0-11, green 12-23, blue 24-35), on and blink
        self._words = {"led_on": 0, "led_blink": 0}
        self._held: dict[str, int] = {}  # RPDO words waiting for the next SYNC (errata G3)
        self._syncs = 0
        self._led_views = _led_views(tuple(self._words), description.led_fields)
        #: bits per colour of the LED word, and the bits that are LEDs (MT M27: not the holes)
        self._led_width = description.pdo("led_on").signal("red").length
        self._led_mask = fill(sum(1 << (k - 1) for k in self._face.led_keys), 7, self._led_width)
        self._shows = startup_shows(self._face.led_keys, self._led_width)
        self._periodic = self.add_timer(self._periodic_key_state)
        self._register_hooks()

    def _register_hooks(self) -> None:
        self.on_write("tpdo1_event_timer", self._schedule_periodic)
        self.on_write("can_protocol", self._on_can_protocol)
        for view in self._led_views:
            self.on_write(view, self._led_view_hook(view), keeps_value=False)
        for prefix in self._words:
            self.on_rpdo(prefix, self._led_rpdo(prefix))
        # the behaviours the description's features switch on (errata G1-G3)
        features = self.description.features
        if "node-id-at-once" in features:  # G1
            self.on_write("node_id", self._on_node_id)
        if "backlight-colour-pdo" in features:  # G2: rev 1.5 §15
            self.on_rpdo("backlight_brightness", self._on_backlight_pdo)
        if self._synchronous:  # G3
            self.on_write("tpdo1_transmission_type", self._on_tpdo_type)
            self.on_frame(SYNC, self._on_sync)  # rev 1.5 §10
        self.on_extended(self._on_extended)
        self.on_boot(self._on_boot)
        self.on_power_off(self._on_power_off)
        self.on_state_change(self._on_state_change)
        self.on_consumer_lost(self._on_consumer_lost)
        self.on_advance(self._on_advance)
        self.add_deadlines(self._deadlines)
        self.on_snapshot(self._snapshot)

    @property
    def demo(self) -> DemoMode | None:
        """DEMO mode's state while it runs (PKP §24), else None."""
        return self._demo

    def set_demo_mode(self, make_demo: Callable[[float], DemoMode]) -> None:
        """How this model's DEMO mode starts (``make_demo(now)``; PKP §24 by default)."""
        self._make_demo = make_demo

    # -- physical side ------------------------------------------------------------------------

    def press(self, key: int, now: float) -> list[Frame]:
        """Press a key (1..12 on the PKP-2600-SI); returns the key-state PDO if one is sent."""
        return self._set_key(self.check_key(key), True, now)

    def release(self, key: int, now: float) -> list[Frame]:
        """Release a key."""
        return self._set_key(self.check_key(key), False, now)

    def check_key(self, key: int) -> int:
        return check_range("key", key, 1, self._face.keys)

    @property
    def keys_pressed(self) -> frozenset[int]:
        return frozenset(item_numbers(self._keys))

    def _set_key(self, key: int, down: bool, now: float) -> list[Frame]:
        check_time("now", now)
        if not self.powered:
            return []
        self.note_time(now)
        bit = 1 << (key - 1)
        keys = self._keys | bit if down else self._keys & ~bit
        if keys == self._keys:
            return []
        self._keys = keys
        self.objects.set("keys_pressed", keys)
        if self._j1939:
            return self._j1939_keypad.key_changed(key, down, keys, now)
        if self._demo is not None:
            if down:
                self._demo.press(key, now)
            else:
                self._demo.release(key, now)
        # PKP §10: sent on every change while operational (event-driven FEh); in SYNC mode
        # only at the SYNCs (rev 1.5 §44a, errata G3)
        if self.nmt_state is not NmtState.OPERATIONAL or self._tpdo_synchronous():
            return []
        return [self._key_state_frame(now)]

    def _key_state_frame(self, now: float) -> Frame:
        # errata P8: byte 4 advances every 100 ms from power-on and wraps
        tick = self.steps_since_boot(now, TICK_PERIOD_S, self._tick_width)
        return Frame(self._key_pdo.cob_id(self.node_id),
                     self._key_pdo.encode({"keys": self._keys, "tick": tick}))

    # -- the LED picture and its object views -------------------------------------------------

    def _led_view_hook(self, name: str) -> Callable[[int, float], None]:
        prefix, shift, mask = self._led_views[name]
        bits = mask << shift
        leds = self._led_mask >> shift  # MT M27: bits that are no LED read back 0
        # the views a write of this one can change: those sharing its bits (itself, where the
        # description's fields do not overlap); found once, not on every write
        touched = [(view, view_shift, view_mask)
                   for view, (view_prefix, view_shift, view_mask) in self._led_views.items()
                   if view_prefix == prefix and (view_mask << view_shift) & bits]
        store = self.objects

        def on_write(value: int, now: float) -> None:
            words = self._words
            word = words[prefix] = (words[prefix] & ~bits) | ((value & leds) << shift)
            for view, view_shift, view_mask in touched:
                store.set(view, (word >> view_shift) & view_mask)

        return on_write

    def _refresh_led_views(self, only: str | None = None) -> None:
        """Bring 2001h/2002h (or only the object ``only`` names) up to date with the words."""
        store = self.objects
        for name, (prefix, shift, mask) in self._led_views.items():
            if only is None or prefix == only:
                store.set(name, (self._words[prefix] >> shift) & mask)

    def _led_rpdo(self, prefix: str) -> Callable[[bytes, float], list[Frame]]:
        layout = self.description.pdo(prefix)

        def on_rpdo(data: bytes, now: float) -> list[Frame]:
            # PKP §11/§12: the whole picture in one frame
            signals = layout.decode(data)
            word = sum(signals[s.name] << s.start for s in layout.signals) & self._led_mask
            if self._rpdo_synchronous(prefix):
                self._held[prefix] = word  # applied at the next SYNC (rev 1.5 §36/§37)
            else:
                self._words[prefix] = word
                self._refresh_led_views(prefix)
            return []

        return on_rpdo

    def _on_backlight_pdo(self, data: bytes, now: float) -> list[Frame]:
        # rev 1.5 §15, errata G2: byte 1 is the colour; 00h or out of range = the default
        # colour; a level over 3Fh ignores the whole frame; DLC 1 changes only the level
        signals = self.description.pdo("backlight_brightness").decode(data)
        level = signals["level"]
        if level > LEVEL_MAX:
            return []
        store = self.objects
        store.set("backlight_brightness", level)
        if len(data) > 1:
            colour = signals["colour"]
            if not BacklightColour.is_code(colour):
                colour = store.get_int("default_backlight_colour")
            store.set("backlight_colour", colour)
        return []

    # -- generation 2: SYNC, node id at once, consumer heartbeat ------------------------------

    def _rpdo_synchronous(self, name: str) -> bool:
        entry = {"led_on": "rpdo1_transmission_type", "led_blink": "rpdo2_transmission_type"}
        return self._synchronous and self.objects.get_int(entry[name]) <= 0xF0

    def _tpdo_synchronous(self) -> bool:
        return self._synchronous and self.objects.get_int("tpdo1_transmission_type") <= 0xF0

    def _on_tpdo_type(self, value: int, now: float) -> None:
        self._syncs = 0  # errata G3: every n-th SYNC counted from the first after the write

    def _on_sync(self, frame: Frame, now: float) -> list[Frame]:
        if self.nmt_state is not NmtState.OPERATIONAL:
            return []
        for name, word in self._held.items():  # the last RPDO before this SYNC wins
            self._words[name] = word
        if self._held:
            self._held = {}
            self._refresh_led_views()
        if not self._tpdo_synchronous():
            return []
        self._syncs += 1
        if self._syncs % self.objects.get_int("tpdo1_transmission_type"):
            return []
        return [self._key_state_frame(now)]  # sampled at this SYNC (rev 1.5 §44a)

    def _on_node_id(self, value: int, now: float) -> None:
        # errata G1 (rev 1.5 §23): the new id is in use at once; the acknowledge comes from it
        self.objects.set("node_id", value)
        self.use_node_id(value)

    def _on_consumer_lost(self, now: float) -> None:
        # rev 1.5 §26 note 2: all LEDs (indicators and backlight) off
        self._words = {"led_on": 0, "led_blink": 0}
        self._held = {}
        self._refresh_led_views()
        self.objects.set("backlight_brightness", 0)

    # -- CANopen hooks ------------------------------------------------------------------------

    def _leave_demo(self, frame: Frame, now: float) -> None:
        # PKP §24: "another command message" leaves DEMO mode. Only while DEMO mode is on is
        # this watcher set, so normal traffic pays nothing for it.
        if frame.can_id == NMT:
            request = parse_nmt(frame, self.description.nmt_aliases)
            if request is None or request.node_id not in (0, self.node_id):
                return
        self._demo = None
        self.watch_frames(None)

    def _on_boot(self, now: float, application: bool) -> list[Frame]:
        self._periodic.stop()
        if application:
            self._show = None
            self._show_mode = self.objects.get_int("startup_led_show")
            steps = self._shows.get(self._show_mode)
            if steps is not None and not self._j1939:
                self._show = ShowPlayer(steps, now)
            # DEMO mode starts at power-on (PKP §24: "disconnect and reconnect")
            demo = self.objects.get_int("demo_mode") and not self._j1939
            self._demo = self._make_demo(now) if demo else None
            if self._demo is not None:
                self.watch_frames(self._leave_demo)
        return []

    def _on_power_off(self) -> None:
        self._words = {"led_on": 0, "led_blink": 0}
        self._held = {}
        self._syncs = 0
        self._keys = 0
        self.objects.set("keys_pressed", 0)
        self._show = None
        self._demo = None  # and its watcher, with the live state
        self._j1939_keypad.power_off()

    def _on_state_change(self, previous: NmtState, state: NmtState, now: float) -> list[Frame]:
        self._schedule_periodic(self.objects.get_int("tpdo1_event_timer"), now)
        return []

    def _schedule_periodic(self, period_ms: int, now: float) -> None:
        # the event timer runs in event-driven mode only (rev 1.5 silent; blinkcan decision)
        operational = self.nmt_state is NmtState.OPERATIONAL and not self._tpdo_synchronous()
        self._periodic.run(now, milliseconds(period_ms), operational)

    def _periodic_key_state(self, now: float) -> list[Frame]:
        return [self._key_state_frame(now)]  # PKP §41b periodic state transmission

    def _on_can_protocol(self, value: int, now: float) -> None:
        if value == PROTOCOL_J1939:
            # Acknowledge first (errata P10), then reboot into J1939, silent on CANopen.
            self.after_reply(self.reset_node)  # J-1: restarts in J1939 mode

    def _on_extended(self, frame: Frame, now: float) -> list[Frame]:
        if not self._j1939:
            return []
        frames = self._j1939_keypad.receive(frame, now)
        if not self._j1939_keypad.wants_canopen:
            return frames
        # §27, J-1, errata "Protocol switch": back to CANopen with CANopen factory defaults;
        # the J1939 settings stay stored
        self._j1939 = False
        self.restore_factory_settings()
        self.objects.set("can_protocol", PROTOCOL_CANOPEN)
        self.save_settings()
        return self.reset_node(now)

    def power_on(self, now: float) -> list[Frame]:
        check_time("now", now)
        if self.powered:
            return []
        self._choose_protocol()
        return self._in_protocol(super().power_on(now), now)

    def reset_node(self, now: float) -> list[Frame]:
        check_time("now", now)
        self._choose_protocol()
        return self._in_protocol(super().reset_node(now), now)

    def _choose_protocol(self) -> None:
        """At power-on and reset node the stored protocol is the one in use (J-1)."""
        stored = self.stored_settings().get("can_protocol", PROTOCOL_CANOPEN)
        self._j1939 = stored == PROTOCOL_J1939

    def _in_protocol(self, canopen_boot: list[Frame], now: float) -> list[Frame]:
        if not self._j1939:
            return canopen_boot
        # J1939 mode: CANopen silent, the J1939 keypad speaks
        self.silence()
        self._show = None
        stored = self.stored_settings()
        self._j1939_keypad.settings.update(self._stored_j1939_settings(stored))
        return self._j1939_keypad.power_on(now, self._keys)

    @staticmethod
    def _stored_j1939_settings(stored: Mapping[str, Any]) -> dict[str, int]:
        prefix = len(NVM_PREFIX)
        return {key[prefix:]: value for key, value in stored.items()
                if key.startswith(NVM_PREFIX) and key[prefix:] in STORED_SETTINGS}

    def _j1939_settings_to_store(self) -> dict[str, Value]:
        """The CANopen and the J1939 settings share the NVM: each write keeps the other's."""
        return {NVM_PREFIX + key: value for key, value in self._j1939_keypad.settings.items()}

    def _save_j1939(self, j1939: dict[str, int]) -> bool:
        return self.save_settings({NVM_PREFIX + key: value for key, value in j1939.items()}) is None

    @property
    def bitrate(self) -> int:
        """The bit rate in use: CANopen's 2010h code, or J1939's 6Fh code (J-3)."""
        if self._j1939:
            return self._j1939_keypad.bitrate
        return super().bitrate

    @property
    def protocol(self) -> str:
        """The protocol in use; while unpowered, the one it will start in (stored)."""
        if not self.powered:
            stored = self.objects.get_int("can_protocol")
            return "j1939" if stored == PROTOCOL_J1939 else "canopen"
        return "j1939" if self._j1939 else "canopen"

    @property
    def j1939(self) -> J1939Keypad:
        """The J1939 side (settings, address), whichever protocol is in use."""
        return self._j1939_keypad

    def _on_advance(self, now: float) -> list[Frame]:
        if self._j1939:
            return self._j1939_keypad.advance(now)
        if self._show is not None and self._show.finished(now):
            self._show = None
        if self._demo is not None:
            self._demo.advance(now)
        return []

    def _deadlines(self, now: float) -> Iterable[float | None]:
        if self._j1939:
            return self._j1939_keypad.deadlines()
        return (
            self._show.next_change(now) if self._show is not None else None,
            self._demo.next_change(now) if self._demo is not None else None,
        )

    # -- what the keypad shows ------------------------------------------------------------------

    def displayed_leds(self, now: float | None = None) -> tuple[int, int]:
        """(on word, blink word) the keys show: the startup show, DEMO mode, or the objects."""
        now = self.last_time if now is None else check_time("now", now)
        if self._j1939:
            return self._j1939_keypad.displayed_leds(now)
        return displayed_words(self._show, self._demo, self._words["led_on"],
                               self._words["led_blink"], now)

    def _backlight(self) -> dict[str, object]:
        if self._demo is not None:
            colour = self._demo.backlight_colour
            level = self._demo.level if colour is not None else 0
            return {"colour": colour.label if colour else "off", "level": level}
        colour_code = self.objects.get_int("backlight_colour")
        return {"colour": BacklightColour(colour_code).label,
                "level": self.objects.get_int("backlight_brightness")}

    def _snapshot(self, now: float) -> dict[str, Any]:
        if self._j1939 and self._j1939_keypad.speaks:
            return {**self._j1939_keypad.snapshot(), "blink_period_s": BLINK_PERIOD_S}
        powered = self.powered
        if not powered:
            on = blink = 0
        else:
            on, blink = self.displayed_leds()
        keys = [
            {"key": key, "pressed": bool(self._keys >> (key - 1) & 1),
             **render_key(on, blink, key, self._led_width)}
            for key in self._face.key_numbers
        ]
        store = self.objects
        indicator = store.get_int("indicator_brightness")
        if self._demo is not None:
            indicator = self._demo.level
        show = None
        if self._show is not None and not self._show.finished(now):
            show = {"mode": SHOW_NAMES[self._show_mode], "step": self._show.step_index(now)}
        return {
            "protocol": "j1939" if self._j1939 else "canopen",
            "keys": keys,
            "indicator_brightness": indicator,
            "backlight": self._backlight() if powered else {"colour": "off", "level": 0},
            "blink_period_s": BLINK_PERIOD_S,
            "startup_show": show,
            "demo": self._demo.describe() if self._demo is not None else None,
            "periodic_key_state_ms": store.get_int("tpdo1_event_timer"),
            "leds": dict(self._words),
            # what the host last commanded, apart from what a show or DEMO mode displays
            "commanded": [render_key(self._words["led_on"], self._words["led_blink"], key,
                                     self._led_width)
                          for key in self._face.key_numbers],
        }
