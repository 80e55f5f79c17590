"""A fuse that blows on a Keybox output running PWM: what the device sends, and what the driver
and the decoder show (last session's noticed list: the driver's ``actual`` said "high").

KBX §18 note and §22 note 2: a fault on pins 12/13 during PWM "will not be transmitted by the
corresponding fault message". The twin follows that: the pin goes FAULT (latched, KBX §7), the
fault PDO is not sent at that moment, and the FAULT is in what the Keybox shows afterwards: a
read of 2001h/2008h, and every later fault message (the periodic one, §25, or another pin's),
whose bytes carry the fault state of every pin (§18). So the driver's ``actual`` keeps "high"
(the last the Keybox showed) until then: not a defect of the twin or of the driver, which shows
what the Keybox showed; ``fault_poll``, ``states()`` or a fault period bring the FAULT in."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from blinkcan.decode.decoder import Decoder
from blinkcan.devices.registry import describe_device
from blinkcan.host import Keybox
from blinkcan.host.keybox import FaultEvent
from blinkcan.testing import Rig
from blinkcan.twin import KeyboxTwin

FACE = describe_device("keybox").face
FAULTS = describe_device("keybox").pdo("faults")


@pytest.fixture
def rig() -> Iterator[Rig]:
    with Rig() as rig:
        yield rig


def _blown_in_pwm(rig: Rig, pin: int) -> tuple[KeyboxTwin, Keybox, list[FaultEvent], int]:
    """A Keybox running ``pin`` at 50 % PWM whose fuse then blows; the driver's fault events,
    and where the wire log stood before the fuse blew."""
    twin = rig.add(KeyboxTwin(node_id=0x0C))
    keybox = Keybox(rig.bus, 0x0C)
    events: list[FaultEvent] = []
    keybox.on_fault(events.append)
    keybox.set_pwm([pin], 5)
    assert keybox.actual[pin] == "high"
    before = len(rig.frames)
    rig.blow_fuse(twin, pin)
    rig.advance(1.0)
    return twin, keybox, events, before


@pytest.mark.parametrize("pin", FACE.pwm_pins)
def test_a_fuse_blown_in_pwm_sends_no_fault_message_and_the_pin_is_fault(
        rig: Rig, pin: int) -> None:
    twin, keybox, events, before = _blown_in_pwm(rig, pin)
    assert list(rig.frames)[before:] == []  # KBX §18 note, §22 note 2: nothing sent
    assert rig.snapshot(twin)["pins"][pin - 1]["state"] == "fault"  # latched (KBX §7)
    assert (keybox.actual[pin], events) == ("high", [])  # the last the Keybox showed
    assert keybox.state(pin) == "fault"  # a read shows it: the driver follows
    assert (keybox.actual[pin], [(e.pin, e.fault) for e in events]) == ("fault", [(pin, True)])
    keybox.close()


@pytest.mark.parametrize("pin", FACE.pwm_pins)
def test_the_periodic_fault_message_carries_it_to_the_driver_and_the_decoder(
        rig: Rig, pin: int) -> None:
    _twin, keybox, events, _before = _blown_in_pwm(rig, pin)
    start = rig.now
    keybox.set_fault_period(0.1)  # KBX §25
    rig.advance(0.25)
    messages = [(time, frame) for time, frame in rig.frames_since(start)
                if frame.can_id == FAULTS.cob_id(0x0C)]
    assert messages
    assert FAULTS.decode(messages[0][1].data)["faults"] == 1 << (pin - 1)
    assert keybox.actual[pin] == "fault"
    assert [(e.pin, e.fault, e.time) for e in events] == [(pin, True, messages[0][0])]
    decoder = Decoder({0x0C: "keybox"})
    assert decoder.text(messages[0][1], messages[0][0]).endswith(f"outputs in FAULT: {pin}")
    keybox.close()
