"""The PKP-3500-MT keypad twin (manual rev 1.3, ``spec/pkp-3500-mt-decisions.md``).

What the PKP-2600-SI twin does (key state, LED words and their views, brightness, SYNC, node id
at once, consumer heartbeat, restore, the J1939 switch) runs here on this model's description
(15 keys, 16 LED bits per colour with holes at the encoders). On top:

- two encoders: a tick counter clamped at TOP or wrapping when TOP = 00h (M34), a direction
  counter of the net movement since that encoder's last PDO (M37), one 295h/395h frame per tick
  while operational (M36, M38), plus an event timer (1801h/1802h sub 05h); the startup value
  written to 2000h/03, /05 is stored, a read returns the live counter (M40);
- ring LEDs: 415h and 2001h/04 (on), 2002h/04 (blink), single colour (M29);
- four analog inputs: 495h every 2006h x 10 ms while operational (M47), 2005h as 8 bits
  (M45), 2004h as digital levels from 2.5 V (M46); 1803h/02 reads the 2006h byte (M12);
- the backlight PDO keeps the colour in use for an out-of-range colour (M51);
- DEMO mode as M75-M81: key-LEDs red, ring LEDs 1 and 17, key 1 cycles the key-LED colour,
  keys 2/3 the brightness, the rings follow the knobs as bar graphs.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

from blinkcan.devices.colours import BACKLIGHT_CHANNELS, BacklightColour, Channel
from blinkcan.devices.keypad import LEVEL_MAX
from blinkcan.devices.keypad_j1939 import DEFAULT_NAME
from blinkcan.devices.model import Quirks
from blinkcan.devices.objects import Value
from blinkcan.devices.pkp3500 import (
    ANALOG_BYTE_MAX,
    ANALOG_COUNTS,
    ANALOG_PERIOD_UNIT_S,
    DIGITAL_THRESHOLD_COUNTS,
    DIRECTION_MAGNITUDE_MAX,
    MODEL,
)
from blinkcan.protocol.abort import AbortCode
from blinkcan.protocol.cob import check_range, check_time
from blinkcan.protocol.frame import Frame
from blinkcan.protocol.j1939 import J1939Name
from blinkcan.protocol.nmt import NmtState
from blinkcan.protocol.sdo import parse_sdo
from blinkcan.twin.keypad import KeypadTwin
from blinkcan.twin.keypad_display import DEMO_COLOURS, DEMO_LEVEL_STEP, DemoMode, fill
from blinkcan.twin.nvm import NvmArgument
from blinkcan.twin.schedule import Periodic, at, ticks

_TICK_RANGE = 0x10000  # MT §12: a 16-bit tick counter
#: M78: a held brightness key (DEMO keys 2 and 3) steps again every 100 ms (the rate is ours:
#: the manual says "holding down", the decision names 100 ms)
_REPEAT_TICKS = ticks(0.1)
#: M15 (Q): the firmware aborts an unknown command specifier with the code the manual lists,
#: 0100 0405h, where CiA 301 says 0504 0001h
_FIRMWARE_UNKNOWN_COMMAND = int(AbortCode.COMMAND_BYTE_INVALID_BLINK).to_bytes(4, "little")


def direction_byte(net: int) -> int:
    """MT §12 (M37): bit 7 = counterclockwise, bits 0-6 = ticks, saturating at 127."""
    magnitude = min(abs(net), DIRECTION_MAGNITUDE_MAX)
    return magnitude | (0x80 if net < 0 and magnitude else 0)


class _Encoder:
    """One knob's live state: tick counter, net movement since its last PDO, its timer."""

    def __init__(self, number: int, timer: Periodic) -> None:
        self.number = number
        self.counter = 0
        self.net = 0
        self.timer = timer
        self.bar = 0  # DEMO mode: ring LEDs lit as a bar graph (M81)


class EncoderDemo(DemoMode):
    """DEMO mode of the PKP-3500-MT (appendix p.61, M75-M81): the key-LEDs in one colour (red
    at first, key 1 steps through the ten colours), keys 2 and 3 the LED brightness, one step
    per press and one more every 100 ms while held (M78), the backlight off. The rings (bar
    graphs of the knobs) are the twin's; key 4's steps are not modelled (other keys have no
    effect, M80)."""

    def __init__(self, now: float, led_mask: int, width: int) -> None:
        super().__init__(now)
        self._led_mask = led_mask
        self._width = width
        #: M78: the brightness key held (2 up, 3 down), when it went down, repeats made
        self._held: tuple[int, float] | None = None
        self._repeats = 0

    @property
    def backlight_colour(self) -> BacklightColour | None:
        return None  # M76: the backlight stays off

    @property
    def key_colour(self) -> BacklightColour | None:
        return DEMO_COLOURS[self.colour_index]

    def press(self, key: int, now: float) -> None:
        if key == 1:  # M77: key 1 (encoder 1's push) steps the key-LED colour
            self.colour_index = (self.colour_index + 1) % len(DEMO_COLOURS)
        elif key in (2, 3):  # M78: LED brightness up / down, repeated while held
            self._held, self._repeats = (key, now), 0
            self._step_level(key)

    def _step_level(self, key: int) -> None:
        """One level step; at the end of the range the held key has nothing left to repeat
        (so a key held for any time costs at most LEVEL_MAX / DEMO_LEVEL_STEP steps)."""
        change = DEMO_LEVEL_STEP if key == 2 else -DEMO_LEVEL_STEP
        self.level = min(LEVEL_MAX, max(0, self.level + change))
        if self.level in (0, LEVEL_MAX):
            self._held = None

    def _next_repeat(self) -> float | None:
        if self._held is None:
            return None
        return at(self._held[1], (self._repeats + 1) * _REPEAT_TICKS)

    def advance(self, now: float) -> None:
        """M78: one more level step for every 100 ms the brightness key has been held."""
        due = self._next_repeat()
        while self._held is not None and due is not None and due <= now:
            self._repeats += 1
            self._step_level(self._held[0])
            due = self._next_repeat()

    def release(self, key: int, now: float) -> None:
        if self._held is not None and self._held[0] == key:
            self.advance(now)
            self._held = None

    def leds(self, now: float) -> tuple[int, int]:
        colour = self.key_colour
        channels = BACKLIGHT_CHANNELS[colour] if colour is not None else Channel.NONE
        return fill(self._led_mask, channels, self._width), 0

    def next_change(self, now: float) -> float | None:
        return self._next_repeat()

    def describe(self) -> dict[str, object]:
        colour = self.key_colour
        return {"key_led_colour": colour.label if colour else "off", "step": None,
                "level": self.level}


class Pkp3500Twin(KeypadTwin):
    """A PKP-3500-MT that behaves on the bus as its manual and the decisions describe.

    Built as ``KeypadTwin(node_id=0x15, model="pkp-3500-mt")`` or directly. Fault injection
    beyond keys: :meth:`turn`, :meth:`set_analog`, :meth:`set_digital_input`. What it does
    beyond the PKP-2600-SI is registered as hooks (encoders, analog inputs, backlight, M15).
    """

    MODEL = MODEL

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
        super().__init__(node_id, quirks, nvm, manual, protocol, name, settings, model)
        description = self.description
        face = description.face
        self._encoders = [_Encoder(e.number, self.add_timer(self._encoder_timer(e.number)))
                          for e in face.encoders]
        self._encoder_layouts = [description.pdo(e.pdo) for e in face.encoders]
        self._analog_layout = description.pdo("analog_inputs")
        self._counts = [0] * face.analog_inputs  # 10 mV units (M44)
        self._analog = self.add_timer(self._analog_frames)
        self._temporary_colour: int | None = None  # M51: set by 515h or 2003h/03 since power-on
        led_width = description.pdo("led_on").signal("red").length
        led_keys = sum(1 << (k - 1) for k in face.led_keys)
        self.set_demo_mode(lambda now: self._encoder_demo(now, led_keys, led_width))
        store = self.objects
        for encoder in self._encoders:
            n = encoder.number
            store.set_reader(f"encoder_{n}_ticks", self._counter_reader(encoder))
            self.on_write(f"encoder_{n}_top", self._top_hook(encoder))
            self.on_write(f"tpdo{n + 1}_event_timer", self._encoder_timer_hook(encoder))
        self.on_write("analog_period", self._on_analog_period)
        self.on_write("backlight_colour", self._on_backlight_colour)
        self.on_rpdo("backlight_brightness", self._temporary_backlight_pdo)
        if description.quirks == "firmware":
            self.filter_sdo_replies(_firmware_abort_code)
        self.on_boot(self._boot_knobs)
        self.on_power_off(self._knobs_power_off)
        self.on_state_change(self._schedule_inputs)
        self.on_consumer_lost(self._rings_off)
        self.on_snapshot(self._knobs_snapshot)

    # -- physical side ------------------------------------------------------------------------

    def turn(self, encoder: int, ticks: int, now: float) -> list[Frame]:
        """Turn encoder 1 or 2 by ``ticks`` (> 0 clockwise, < 0 counterclockwise; 16 = one
        turn). Returns one encoder PDO per tick while operational (M36, M38)."""
        knob = self._encoders[check_range("encoder", encoder, 1, len(self._encoders)) - 1]
        if isinstance(ticks, bool) or not isinstance(ticks, int):
            raise TypeError(f"ticks must be an int, not {type(ticks).__name__}")
        check_time("now", now)
        if not self.powered or not ticks:
            return []
        self.note_time(now)
        step = 1 if ticks > 0 else -1
        frames = []
        for _ in range(abs(ticks)):
            self._tick(knob, step)
            if self._sends_pdos():
                frames.append(self._encoder_frame(knob))
        return frames

    def set_analog(self, input: int, volts: float, now: float) -> list[Frame]:
        """Put ``volts`` on input IN0..IN3 (above 5 V reads full scale, M45). The 495h PDO
        carries it at its next period."""
        check_range("input", input, 0, len(self._counts) - 1)
        if isinstance(volts, bool) or not isinstance(volts, (int, float)) \
                or not 0 <= volts < float("inf"):  # NaN fails the comparison
            raise ValueError(f"volts must be a number >= 0, not {volts!r}")
        check_time("now", now)
        self.note_time(now)
        # 10 mV per count (M44); above full scale, however far (1e308 V), full scale (M45)
        self._counts[input] = min(ANALOG_COUNTS, round(min(volts, ANALOG_COUNTS / 100) * 100))
        self._refresh_inputs()
        return []

    def set_digital_input(self, input: int, level: bool, now: float) -> list[Frame]:
        """Drive input IN0..IN3 high (5 V) or low (0 V); 2004h reads it from 2.5 V (M46).
        ``level``: a bool, or 1 / 0."""
        if not isinstance(level, int):  # bool is an int; NaN, "1" and None were "high"
            raise TypeError(f"level must be a bool (or 1 / 0), not {type(level).__name__}")
        if level not in (0, 1):
            raise ValueError(f"level must be 0 or 1 (or a bool), not {level!r}")
        return self.set_analog(input, 5.0 if level else 0.0, now)

    def _refresh_inputs(self) -> None:
        digital = 0
        store = self.objects
        for n, count in enumerate(self._counts):
            # M45: 2005h = round(count * 255 / 500); M46: a 1 from 2.5 V
            store.set(f"analog_input_{n}", min(ANALOG_BYTE_MAX, round(count * 255 / 500)))
            digital |= (count >= DIGITAL_THRESHOLD_COUNTS) << n
        store.set("digital_inputs", digital)

    # -- encoders -------------------------------------------------------------------------------

    def _top(self, knob: _Encoder) -> int:
        return self.objects.get_int(f"encoder_{knob.number}_top")

    def _tick(self, knob: _Encoder, step: int) -> None:
        top = self._top(knob)
        if top:  # M34: clamp to [0, TOP]
            knob.counter = min(top, max(0, knob.counter + step))
        else:  # M34: TOP 00h wraps both ways
            knob.counter = (knob.counter + step) % _TICK_RANGE
        knob.net += step  # M37: ticks count even when clamped
        self.objects.set(f"encoder_{knob.number}_direction", direction_byte(knob.net))
        if self.demo is not None:
            self._demo_tick(knob, step)

    def _encoder_frame(self, knob: _Encoder) -> Frame:
        layout = self._encoder_layouts[knob.number - 1]
        data = layout.encode({"direction": direction_byte(knob.net), "ticks": knob.counter,
                              "top": self._top(knob)})
        knob.net = 0  # M37: reset when the PDO is sent
        self.objects.set(f"encoder_{knob.number}_direction", 0)
        return Frame(layout.cob_id(self.node_id), data)

    def _encoder_timer(self, number: int) -> Callable[[float], list[Frame]]:
        def produce(now: float) -> list[Frame]:
            return [self._encoder_frame(self._encoders[number - 1])]  # M38: also when still

        return produce

    def _counter_reader(self, knob: _Encoder) -> Callable[[], bytes]:
        def read() -> bytes:
            return knob.counter.to_bytes(2, "little")  # M40: a read gives the live counter

        return read

    def _top_hook(self, knob: _Encoder) -> Callable[[int, float], None]:
        def on_write(value: int, now: float) -> None:
            if value and knob.counter > value:  # M39: a lower TOP clamps at once, no PDO
                knob.counter = value

        return on_write

    def _encoder_timer_hook(self, knob: _Encoder) -> Callable[[int, float], None]:
        def on_write(value: int, now: float) -> None:
            self._schedule_encoder(knob, value, now)

        return on_write

    def _schedule_encoder(self, knob: _Encoder, period_ms: int, now: float) -> None:
        knob.timer.start(period_ms / 1000, now, self._sends_pdos())

    def _sends_pdos(self) -> bool:
        return self.nmt_state is NmtState.OPERATIONAL and self.protocol == "canopen"

    # -- analog inputs --------------------------------------------------------------------------

    def _analog_period(self) -> float:
        return self.objects.get_int("analog_period") * ANALOG_PERIOD_UNIT_S

    def _on_analog_period(self, value: int, now: float) -> None:
        self.objects.set("tpdo4_transmission_type", value)  # M12: 1803h/02 reads this byte
        if self._analog.running:  # M47: a write restarts the period
            self._analog.start(value * ANALOG_PERIOD_UNIT_S, now)

    def _analog_frames(self, now: float) -> list[Frame]:
        layout = self._analog_layout
        data = layout.encode({f"in{n}": count for n, count in enumerate(self._counts)})
        self._analog.period = self._analog_period()  # M47: the period 2006h holds now
        return [Frame(layout.cob_id(self.node_id), data)]

    # -- backlight (M51-M53) --------------------------------------------------------------------

    def _on_backlight_colour(self, value: int, now: float) -> None:
        self._temporary_colour = value  # M53: 2003h/03 is a temporary colour

    def _temporary_backlight_pdo(self, data: bytes, now: float) -> list[Frame]:
        # MT §18 note 1 (M52): a level over 3Fh ignores the whole frame; DLC 1: level only
        # (M54); note 2 (M51): a colour out of 01h-09h keeps the colour in use
        signals = self.description.pdo("backlight_brightness").decode(data)
        level = signals["level"]
        if level > LEVEL_MAX:
            return []
        store = self.objects
        store.set("backlight_brightness", level)
        colour = signals["colour"]
        if len(data) > 1 and BacklightColour.is_code(colour):
            self._temporary_colour = colour
            store.set("backlight_colour", colour)
        return []

    # -- CANopen hooks --------------------------------------------------------------------------

    def _boot_knobs(self, now: float, application: bool) -> list[Frame]:
        store = self.objects
        if application:
            for knob in self._encoders:  # M40: from the startup value, at most TOP
                startup = store.get_int(f"encoder_{knob.number}_ticks")
                top = self._top(knob)
                knob.counter = min(startup, top) if top else startup
                knob.net = 0
                store.set(f"encoder_{knob.number}_direction", 0)
            self._temporary_colour = None
            self._refresh_inputs()
        store.set("tpdo4_transmission_type", store.get_int("analog_period"))
        return []

    def _knobs_power_off(self) -> None:
        self._counts = [0] * len(self._counts)  # M46: nothing connected
        self.objects.set("led_on_rings", 0)
        self.objects.set("led_blink_rings", 0)

    def _schedule_inputs(self, previous: NmtState, state: NmtState, now: float) -> list[Frame]:
        for knob in self._encoders:
            self._schedule_encoder(
                knob, self.objects.get_int(f"tpdo{knob.number + 1}_event_timer"), now)
        # M47: the first 495h one period after entering operational
        self._analog.start(self._analog_period(), now, self._sends_pdos())
        return []

    def _rings_off(self, now: float) -> None:
        # after the key-LEDs, blink and backlight (the keypad's hook)
        self.objects.set("led_on_rings", 0)  # M65: the ring LEDs too
        self.objects.set("led_blink_rings", 0)

    def _encoder_demo(self, now: float, led_keys: int, led_width: int) -> DemoMode:
        for knob in self._encoders:
            knob.bar = 1  # M76: LEDs 1 and 17 lit
        return EncoderDemo(now, led_keys, led_width)

    # -- what the keypad shows ------------------------------------------------------------------

    def rings(self) -> tuple[int, int]:
        """(on, blink) of the 32 ring LEDs (bit n-1 = LED n, M26): the objects or DEMO mode."""
        if self.demo is not None:
            return self._demo_rings(), 0
        return self.objects.get_int("led_on_rings"), self.objects.get_int("led_blink_rings")

    def _demo_rings(self) -> int:
        # M76: LEDs 1 and 17 at start; M81: each ring a bar graph from its first LED
        bits = 0
        for knob, encoder in zip(self._encoders, self.description.face.encoders, strict=True):
            lit = knob.bar
            first = encoder.ring_leds[0]
            bits |= ((1 << lit) - 1) << (first - 1)
        return bits

    def _demo_tick(self, knob: _Encoder, step: int) -> None:
        size = len(self.description.face.encoders[knob.number - 1].ring_leds)
        knob.bar = min(size, max(0, knob.bar + step))

    def _knobs_snapshot(self, now: float) -> dict[str, Any]:
        showing = self.powered and self.protocol == "canopen"
        on, blink = self.rings() if showing else (0, 0)
        encoders = []
        for knob, encoder in zip(self._encoders, self.description.face.encoders, strict=True):
            encoders.append({
                "encoder": knob.number,
                "key": encoder.key,
                "counter": knob.counter,
                "top": self._top(knob),
                "ring": [{"led": led, "on": bool(on >> (led - 1) & 1),
                          "blink": bool(blink >> (led - 1) & 1)} for led in encoder.ring_leds],
            })
        return {
            "encoders": encoders,
            "analog_inputs": [
                {"input": n, "volts": count / 100, "count": count,
                 "digital": count >= DIGITAL_THRESHOLD_COUNTS}
                for n, count in enumerate(self._counts)],
            "analog_period_ms": self.objects.get_int("analog_period") * 10,
        }


def _firmware_abort_code(reply: bytes) -> bytes:
    """M15 (Q): the firmware's abort code for an unknown command specifier."""
    parsed = parse_sdo(reply)  # the server's replies are eight bytes
    if parsed.is_abort and parsed.word == AbortCode.COMMAND_SPECIFIER_INVALID:
        return reply[:4] + _FIRMWARE_UNKNOWN_COMMAND
    return reply


__all__ = ["EncoderDemo", "Pkp3500Twin", "direction_byte"]
