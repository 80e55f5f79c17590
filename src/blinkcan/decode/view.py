"""What the bus says about each device, followed event by event (for ``blinkcan monitor``).

Only what traffic shows: NMT state from heartbeats, the keypad's LED picture from its LED
PDOs, the keys held from its key-state PDOs, the Keybox's outputs as commanded (RPDO, 2001h and
2008h writes) and as reported (the fault PDO, 2008h reads).

What a device does by itself is followed by the twins' fail-safe rules (README "Decisions"):
a boot-up means outputs OFF, LEDs dark and FAULT latches cleared (so does an NMT reset); an NMT
stop, or a heartbeat saying "stopped", switches HIGH outputs OFF; a device that goes from
operational to pre-operational with no NMT command asking for it tripped its consumer heartbeat
(KBX §28, PKP rev 1.5 §26): HIGH outputs OFF, LEDs dark. FAULT stays latched through all but a
reset.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from blinkcan.decode.decoder import Decoder, Event, Kind
from blinkcan.decode.describers import numbers
from blinkcan.devices.colours import Channel, blink_phases, channel_name
from blinkcan.devices.keybox import PWM_LEVEL_MAX, commanded_outputs
from blinkcan.devices.keypad_j1939 import LedLook, LedState, look_channels, look_phases
from blinkcan.devices.model import Face
from blinkcan.devices.registry import describe_device

#: the PDOs followed field by field; any other PDO is kept as its latest meaning
_FOLLOWED = frozenset({"led_on", "led_blink", "key_state", "outputs", "faults"})
_NMT_STATES = {"start": "operational", "stop": "stopped", "stop (legacy 00h)": "stopped",
               "enter pre-operational": "pre-operational"}
_RESETS = ("reset node", "reset communication")


@dataclass
class NodeView:
    node_id: int
    device: str | None = None
    state: str = "unknown"
    leds: dict[str, list[int]] = field(default_factory=dict)  # colour -> keys lit
    blink: dict[str, list[int]] = field(default_factory=dict)
    held: list[int] = field(default_factory=list)
    outputs: dict[int, str] = field(default_factory=dict)
    face: Face = field(default_factory=Face)  # the model's keys and pins, once known
    #: the state the last NMT command to this node asked for (None: none seen, or a reset)
    asked: str | None = None
    #: PDO name -> what its last frame meant (encoders, analog inputs, ring LEDs, ...)
    other: dict[str, str] = field(default_factory=dict)
    #: pins in PWM (KBX §22, object "pwm"): pin -> duty in percent
    pwm: dict[int, int] = field(default_factory=dict)
    #: J1939 mode: key -> (phase A, phase B) by the §7a colour names commanded ("amber")
    named: dict[int, tuple[str, str]] = field(default_factory=dict)

    def know(self, face: Face) -> None:
        if face != self.face:
            self.face = face
            self.outputs = dict.fromkeys(face.pin_numbers, "off")

    def outputs_off(self) -> None:
        """Fail-safe: every HIGH output OFF, PWM stopped, FAULT latched."""
        self.pwm = {}
        self.outputs = {pin: "fault" if state == "fault" else "off"
                        for pin, state in self.outputs.items()}

    def reboot(self) -> None:
        """Power-on or reset: pre-operational, outputs OFF, no FAULT, LEDs dark, no key held."""
        self.state, self.leds, self.blink, self.held = "pre-operational", {}, {}, []
        self.named = {}
        self.outputs = dict.fromkeys(self.face.pin_numbers, "off")
        self.pwm, self.asked = {}, None

    def reported(self, state: str) -> None:
        """A heartbeat's state; a change the last NMT command did not ask for is a trip."""
        if state == "stopped":
            self.outputs_off()
        elif (self.state, state) == ("operational", "pre-operational") \
                and self.asked != "pre-operational":
            self.outputs_off()  # the watchdog tripped: KBX §28, PKP rev 1.5 §26 note 2
            self.leds, self.blink = {}, {}
        self.state = state

    def key_colours(self) -> list[tuple[int, str, str]]:
        """(key, steady colour, blink colour) for every key of the model."""
        def colour(picture: dict[str, list[int]], key: int) -> str:
            channels = sum(bit for name, bit in (("red", 1), ("green", 2), ("blue", 4))
                           if key in picture.get(name, []))
            return channel_name(channels)

        return [(key, colour(self.leds, key), colour(self.blink, key))
                for key in self.face.key_numbers]

    def key_phases(self) -> list[tuple[int, str, str]]:
        """(key, colour in blink phase A, in phase B): the same twice for a steady LED, one
        "off" for a blinking one, two colours for an alternating one (colours.blink_phases)."""
        def channels(picture: dict[str, list[int]], key: int) -> int:
            return sum(bit for name, bit in (("red", 1), ("green", 2), ("blue", 4))
                       if key in picture.get(name, []))

        found = []
        for key in self.face.key_numbers:
            if key in self.named:  # J1939: the colour as commanded, amber is not yellow
                found.append((key, *self.named[key]))
                continue
            a, b = blink_phases(channels(self.leds, key), channels(self.blink, key))
            found.append((key, channel_name(a), channel_name(b)))
        return found


def _mask(pins: object) -> int:
    """The mask of an event's pin list (pin 1 = bit 0)."""
    return sum(1 << (pin - 1) for pin in pins)  # type: ignore[attr-defined]


def _follow_j1939(view: NodeView, fields: dict[str, object]) -> None:
    """A keypad in J1939 mode (spec/pkp-2600-si-j1939.md): keys held from its key messages and
    heartbeats, LEDs from single-LED commands, on the CANopen picture (J-4)."""
    view.state = "J1939"
    message, command = fields.get("message"), fields.get("command")
    if message == "key" and isinstance(key := fields.get("key"), int):
        held = set(view.held) - {key}
        view.held = sorted(held | {key} if fields.get("pressed") else held)
    elif message == "heartbeat" and isinstance(keys := fields.get("keys"), list):
        view.held = list(keys)
    elif command == "single_led":
        key = int(fields["key"])  # type: ignore[call-overload]
        look = LedLook(LedState(fields["state"]), int(fields["colour"]),  # type: ignore[call-overload]
                       int(fields["secondary"]))  # type: ignore[call-overload]
        view.named[key] = look_phases(look)
        on, blink = look_channels(look)
        for picture, channels in ((view.leds, on), (view.blink, blink)):
            for name, channel in (("red", Channel.RED), ("green", Channel.GREEN),
                                  ("blue", Channel.BLUE)):
                keys_lit = set(picture.get(name, [])) - {key}
                picture[name] = sorted(keys_lit | {key} if channels & channel else keys_lit)


class BusView:
    """``decoder`` (the one making the events) tells each node's model; without it the
    device names of the events are looked up in the model registry."""

    def __init__(self, decoder: Decoder | None = None) -> None:
        self.nodes: dict[int, NodeView] = {}
        self.decoder = decoder

    def _face(self, node_id: int, device: str | None) -> Face | None:
        description = self.decoder.device(node_id) if self.decoder is not None else None
        if description is None and device is not None:
            try:
                description = describe_device(device)
            except ValueError:
                return None
        return description.face if description is not None else None

    def node(self, node_id: int) -> NodeView:
        view = self.nodes.get(node_id)
        if view is None:
            view = self.nodes[node_id] = NodeView(node_id)
        return view

    def update(self, event: Event) -> None:
        if event.kind is Kind.NMT:
            command = event.fields.get("command", "")
            state = _NMT_STATES.get(command)
            target = event.fields.get("target", 0)
            targets = self.nodes.values() if target == 0 else [self.node(target)]
            for view in targets:
                if command in _RESETS:
                    view.reboot()
                elif state is not None:
                    view.asked = view.state = state
                    if state == "stopped":
                        view.outputs_off()
            return
        if event.node_id is None:
            return
        view = self.node(event.node_id)
        view.device = event.device or view.device
        face = self._face(event.node_id, view.device)
        if face is not None:
            view.know(face)
        fields = event.fields
        if event.kind is Kind.BOOT_UP:
            view.reboot()
        elif event.kind is Kind.HEARTBEAT:
            view.reported(fields.get("state", view.state))
        elif event.kind is Kind.PDO:
            if fields.get("pdo") in _FOLLOWED:
                self._pdo(view, fields)
            else:
                view.other[str(fields.get("pdo"))] = event.text
        elif event.kind in (Kind.SDO_WRITE, Kind.SDO_VALUE):
            self._object(view, event.kind, fields)
        elif event.kind is Kind.J1939 and view.face.keys:  # a keypad in J1939 mode
            _follow_j1939(view, fields)

    @staticmethod
    def _pdo(view: NodeView, fields: dict[str, object]) -> None:
        name = fields.get("pdo")
        if name == "led_on":
            view.leds = {c: list(fields[c]) for c in ("red", "green", "blue")}  # type: ignore[call-overload]
        elif name == "led_blink":
            view.blink = {c: list(fields[c]) for c in ("red", "green", "blue")}  # type: ignore[call-overload]
        elif name == "key_state":
            view.held = list(fields["held"])  # type: ignore[call-overload]
        elif name == "outputs":  # KBX §17: OFF wins (devices/keybox.py commanded_outputs)
            off, high = commanded_outputs(_mask(fields["off"]), _mask(fields["high"]))
            for state, mask in (("off", off), ("high", high)):
                for pin in numbers(mask):
                    if view.outputs.get(pin) != "fault":  # FAULT stays latched (KBX §18)
                        view.outputs[pin] = state
        elif name == "faults":
            for pin in view.face.pin_numbers:
                if pin in fields["faults"]:  # type: ignore[operator]
                    view.outputs[pin] = "fault"
                elif view.outputs[pin] == "fault":
                    view.outputs[pin] = "off"

    @staticmethod
    def _object(view: NodeView, kind: Kind, fields: dict[str, object]) -> None:
        index, sub, value = fields.get("index"), fields.get("subindex"), fields.get("value")
        # the output objects (KBX §19, §22): only a model whose face has output pins
        if not view.face.pins or not isinstance(value, int) or not isinstance(sub, int):
            return
        if fields.get("object") == "pwm":  # KBX §22: byte 0 the PWM pins, byte 1 the duty
            level = value >> 8
            view.pwm = {pin: level * 100 // PWM_LEVEL_MAX
                        for bit, pin in enumerate(view.face.pwm_pins) if value >> bit & 1}
            return
        if index == 0x2001 and sub in view.outputs and kind is Kind.SDO_WRITE:
            view.outputs[sub] = {0: "off", 1: "high", 2: "off"}.get(value, view.outputs[sub])
        elif index == 0x2008 and sub in (1, 2, 3):
            state = {1: "off", 2: "high", 3: "fault"}[sub]
            for pin in view.face.pin_numbers:
                if value >> (pin - 1) & 1:
                    view.outputs[pin] = state
