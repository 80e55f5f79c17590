"""The PKP-3500-MT driver: everything :class:`Keypad` does (keys, key-LEDs, backlight,
configuration) on this model's description, plus its encoders, ring LEDs and inputs.

Built as ``Keypad(bus, 0x15, model="pkp-3500-mt")``, ``Keypad.connect(bus, 0x15)`` (which reads
100Bh) or directly. § numbers are the PKP-3500-MT manual's (MT), M-numbers its decisions.
"""

from __future__ import annotations

import threading
from collections.abc import AsyncIterator, Callable, Iterable, Iterator
from dataclasses import dataclass
from typing import Any

import can

from blinkcan.devices.keypad import LEVEL_MAX
from blinkcan.devices.pkp3500 import GENERATION, MODEL
from blinkcan.host.aio import AsyncDriver
from blinkcan.host.bus import HostBus
from blinkcan.host.device import Device
from blinkcan.host.events import EventSource
from blinkcan.host.keypad import KeyEvent, Keypad
from blinkcan.protocol.cob import check_range
from blinkcan.protocol.frame import Frame
from blinkcan.protocol.items import item_mask, item_numbers


@dataclass(frozen=True)
class EncoderEvent:
    """An encoder PDO (MT §12/§13): ``ticks`` moved since the previous one (> 0 clockwise,
    M37), the tick ``counter`` and the ``top`` it is clamped at (0: it wraps, M34)."""

    encoder: int
    ticks: int
    counter: int
    top: int
    time: float

    @property
    def direction(self) -> str:
        return "clockwise" if self.ticks > 0 else "counterclockwise" if self.ticks < 0 else "none"


def _integer(what: str, value: int) -> int:
    """``value`` if it is an int (not a bool); else TypeError naming the type expected (a
    wrong type is not a value out of range: the project's argument rule)."""
    if isinstance(value, bool) or not isinstance(value, int):
        raise TypeError(f"{what} must be an int, not {type(value).__name__}")
    return value


def _led_numbers(leds: Iterable[int]) -> list[int]:
    """``leds`` as a list of ints; TypeError for a text ("123" is no list of LEDs), a lone
    number, None, or an item that is no int (a bool, a float, a digit as text)."""
    if isinstance(leds, (str, bytes)) or not isinstance(leds, Iterable):
        raise TypeError("leds must be an iterable of LED numbers (ints), not "
                        f"{type(leds).__name__}")
    return [_integer("ring LED", led) for led in leds]


class Pkp3500Keypad(Keypad):
    """Drive a PKP-3500-MT at ``node_id`` on ``bus``. Options as :class:`Keypad`."""

    def __init__(self, bus: HostBus | can.BusABC, node_id: int = 0x15, *, model: str = MODEL,
                 **options: Any) -> None:
        if model != MODEL:
            raise ValueError(f"this driver runs model {MODEL!r}, not {model!r}")
        super().__init__(bus, node_id, generation=GENERATION, model=MODEL, **options)
        face = self.description.face
        self.encoders = EventSource[EncoderEvent](self.host.scheduler)
        #: the last encoder state each encoder reported: (counter, top)
        self.encoder_states: dict[int, tuple[int, int]] = {}
        #: volts of IN0..IN3 from the last 495h PDO (10 mV resolution, M44)
        self.analog: dict[int, float] = {}
        self._rings: int | None = None  # the ring LEDs last set, restored after a boot-up
        #: the ring LEDs are changed and sent under it (by the application's threads and the
        #: bus thread's restore), so the last ring PDO sent is always the rings as they are
        self._rings_lock = threading.RLock()
        for encoder in face.encoders:
            layout = self.description.pdo(encoder.pdo)
            self.listen(layout.cob_id(node_id), self._encoder_handler(encoder.number))
        analog = self.description.pdo("analog_inputs")
        self.listen(analog.cob_id(node_id), self._on_analog)

    @property
    def generation(self) -> str:
        return GENERATION  # one firmware generation, with the rev 1.5 features (M-intro)

    def watch_host(self, period: float) -> None:
        """The keypad switches its LEDs off (rings too) when the controller's heartbeat
        stops (MT §32, M65)."""
        Device.watch_host(self, period)

    # -- encoders ---------------------------------------------------------------------------------

    def on_encoder(self, callback: Callable[[EncoderEvent], object]) -> Callable[[], None]:
        """Call ``callback(event)`` on the bus thread for every encoder PDO."""
        return self.encoders.subscribe(callback)

    def encoder_events(self, timeout: float | None = None) -> Iterator[EncoderEvent]:
        """Encoder events from now on, in this thread; stops after ``timeout`` s without one."""
        return self.encoders.iterate(timeout)

    def _encoder_handler(self, number: int) -> Callable[[Frame, float], None]:
        face = self.description.face
        layout = self.description.pdo(face.encoders[number - 1].pdo)
        direction = layout.signal("direction")

        def on_frame(frame: Frame, now: float) -> None:
            if len(frame.data) < layout.min_length:
                return
            values = layout.decode(frame.data)
            ticks = int(direction.physical(values["direction"]))  # sign-magnitude (M37)
            self.encoder_states[number] = (values["ticks"], values["top"])
            self.encoders.emit(EncoderEvent(number, ticks, values["ticks"], values["top"], now))

        return on_frame

    def _check_encoder(self, encoder: int) -> int:
        return check_range("encoder", encoder, 1, len(self.description.face.encoders))

    def set_top(self, encoder: int, top: int) -> None:
        """The counter of ``encoder`` stops at ``top`` (2..16) clockwise and at 0; 0: it counts
        0..65535 and wraps (MT §19f/g, M34, M39). Stored."""
        self.write(f"encoder_{self._check_encoder(encoder)}_top", _integer("top", top))

    def set_startup_counter(self, encoder: int, value: int) -> None:
        """The counter ``encoder`` starts from at power-on (at most TOP, M40). Stored."""
        self.write(f"encoder_{self._check_encoder(encoder)}_ticks",
                   _integer("startup counter", value))

    def read_counter(self, encoder: int) -> int:
        """The live tick counter (SDO 2000h/03 or /05, M40)."""
        return int(self.read(f"encoder_{self._check_encoder(encoder)}_ticks"))

    def set_encoder_period(self, encoder: int, period: float) -> None:
        """Also send the encoder's state every ``period`` s (0: only when turned; 0.05..65.279,
        MT §51/§52, M72)."""
        self.write_period(f"tpdo{self._check_encoder(encoder) + 1}_event_timer",
                          "encoder period", period)

    # -- ring LEDs (MT §17, §20c, §21c) ----------------------------------------------------------

    def set_ring(self, encoder: int, leds: Iterable[int]) -> None:
        """Light exactly ``leds`` of ``encoder``'s ring (numbered as the face, LED 1 / 17 at six
        o'clock, clockwise, M26); the other ring keeps its LEDs. Sent as the 415h PDO."""
        ring = self.description.face.encoders[self._check_encoder(encoder) - 1].ring_leds
        chosen = set(_led_numbers(leds))
        if not chosen <= set(ring):
            raise ValueError(f"ring {encoder} has LEDs {ring[0]}..{ring[-1]}, not "
                             f"{sorted(chosen - set(ring))}")
        own = sum(1 << (led - 1) for led in chosen)
        with self._rings_lock:  # the other ring's LEDs as they are now, not as read before
            others = (self._rings or 0) & ~sum(1 << (led - 1) for led in ring)
            self._send_rings(others | own)

    def read_rings(self) -> list[int]:
        """Take the ring LEDs the keypad shows now (SDO, MT §20c) as this driver's picture, so
        that the next :meth:`set_ring` changes one ring and keeps the other as it is (a program
        started against a keypad lit by someone else). Returns the LEDs lit."""
        word = int(self.read("led_on_rings"))  # no SDO under the picture lock
        with self._rings_lock:
            self._rings = word
        return item_numbers(word)

    def ring(self, encoder: int) -> list[int]:
        """The ring LEDs of ``encoder`` this driver last set."""
        ring = self.description.face.encoders[self._check_encoder(encoder) - 1].ring_leds
        return [led for led in item_numbers(self._rings or 0) if led in ring]

    def set_ring_blink(self, leds: Iterable[int]) -> None:
        """Ring LEDs that blink (1..32; only by SDO 2002h/04, M29)."""
        self.write("led_blink_rings", item_mask(_led_numbers(leds), "ring LED", 32))

    def _send_rings(self, word: int) -> None:
        with self._rings_lock:
            self._rings = word
            self.send_shown(self.pdo_frame("ring_leds", {"rings": word}))

    # -- inputs (MT §14, §23, §24) -----------------------------------------------------------------

    def _on_analog(self, frame: Frame, now: float) -> None:
        layout = self.description.pdo("analog_inputs")
        if len(frame.data) < layout.min_length:
            return
        values = layout.decode(frame.data)
        for signal in layout.signals:
            self.analog[int(signal.name[2:])] = float(signal.physical(values[signal.name]))

    def read_analog(self, input: int) -> float:
        """Volts on IN0..IN3 by SDO 2005h (8 bits, 5 V = FFh, M45)."""
        count = len(self.analog_inputs_range())
        check_range("input", input, 0, count - 1)
        byte = int(self.read(f"analog_input_{input}"))
        return round(byte * self.description.face.analog_volts_max / 0xFF, 3)

    def analog_inputs_range(self) -> range:
        return range(self.description.face.analog_inputs)

    def digital_inputs(self) -> dict[int, bool]:
        """IN0..IN3 as levels (2004h: high from 2.5 V, M46)."""
        bits = int(self.read("digital_inputs"))
        return {n: bool(bits >> n & 1) for n in range(self.description.face.digital_inputs)}

    def set_analog_period(self, period: float) -> None:
        """The 495h PDO every ``period`` s, 0.08..2 in 10 ms steps (MT §25, M47). Stored."""
        self.write_period("analog_period", "analog period", period, 0.01)

    # -- what differs from the PKP-2600-SI --------------------------------------------------------

    def set_brightness(self, level: int) -> None:
        """Key-LED and ring brightness 0..63 by SDO 2003h/01: this keypad has no brightness
        PDO, its 415h is the ring LEDs (M29, M56)."""
        check_range("brightness", level, 0, LEVEL_MAX)
        self.write("indicator_brightness", level)

    def send_picture_again(self, leds_unsent: bool = True) -> None:
        """The key LEDs and levels, and the ring LEDs (after a reboot, a watchdog trip (MT
        §32: rings off too) or a start after a stop)."""
        super().send_picture_again(leds_unsent)
        with self._rings_lock:
            if self._rings is not None:
                self.send_shown(self.pdo_frame("ring_leds", {"rings": self._rings}))


class AsyncPkp3500Keypad(AsyncDriver[Pkp3500Keypad]):
    """The asyncio face, as ``AsyncKeypad``: ``await keypad.set_ring(1, [1, 2])``,
    ``async for event in keypad.encoder_events()``."""

    _driver = Pkp3500Keypad

    def events(self, timeout: float | None = None) -> AsyncIterator[KeyEvent]:
        return self.stream(lambda device: device.keys, timeout)

    def encoder_events(self, timeout: float | None = None) -> AsyncIterator[EncoderEvent]:
        return self.stream(lambda device: device.encoders, timeout)
