"""Every registered model the plain keypad driver runs (the PKP-2600-SI and its byte-padded
siblings), through scan, Keypad.connect, key events, LEDs, the decoder and the DBC: parametrised
over the registry, so a new model's registry line puts it here."""

from __future__ import annotations

import cantools
import pytest

from blinkcan.decode import Decoder
from blinkcan.devices.registry import models
from blinkcan.formats.dbc import dbc_text
from blinkcan.host import Keypad, scan
from blinkcan.host.keypad import KeyEvent
from blinkcan.protocol import Frame
from blinkcan.testing import Rig
from blinkcan.twin import KeypadTwin

PLAIN = [m.name for m in models() if m.driver == "blinkcan.host.keypad:Keypad"]


@pytest.mark.parametrize("name", PLAIN)
def test_scan_and_connect_identify_the_model(name: str) -> None:
    with Rig() as rig:
        rig.add(KeypadTwin(node_id=0x15, model=name))
        found = {f.node_id: f.model for f in scan(rig.bus, listen=0.05)}
        assert found == {0x15: name}
        keypad = Keypad.connect(rig.bus, 0x15, start=False)
        assert keypad.description.model == name
        keypad.close()


@pytest.mark.parametrize("name", PLAIN)
def test_the_driver_drives_every_key_and_led(name: str) -> None:
    with Rig() as rig:
        twin = rig.add(KeypadTwin(node_id=0x15, model=name))
        keypad = Keypad.connect(rig.bus, 0x15)
        rig.settle()
        face = twin.description.face
        last = face.keys
        seen: list[KeyEvent] = []
        keypad.on_key(seen.append)
        rig.act(lambda now: twin.press(last, now))
        rig.settle()
        assert [(e.key, e.action) for e in seen][:1] == [(last, "press")]
        keypad.set_led(last, "green", blink="red")
        keypad.set_led(1, "blue")
        rig.settle()
        shown = twin.snapshot()["commanded"]  # the startup show may still run
        assert len(shown) == last
        assert shown[last - 1]["phases"] == ["green", "red"]
        assert shown[0]["colour"] == "blue"
        with pytest.raises(ValueError, match=str(last)):
            keypad.set_led(last + 1, "red")
        keypad.close()


@pytest.mark.parametrize("name", PLAIN)
def test_decoder_and_dbc_name_the_key_and_led_frames(name: str) -> None:
    description = KeypadTwin(node_id=0x15, model=name).description
    last = description.face.keys
    leds, keys = description.pdo("led_on"), description.pdo("key_state")
    led_frame = Frame(leds.cob_id(0x15), leds.encode({"green": 1 << (last - 1)}))
    key_frame = Frame(keys.cob_id(0x15), keys.encode({"keys": 1 << (last - 1)}))
    decoder = Decoder({0x15: name})
    assert str(decoder.decode(led_frame)) == f"keypad 15h: LEDs on: green {last}"
    assert str(decoder.decode(key_frame)) == f"keypad 15h: key {last} pressed"
    database = cantools.database.load_string(dbc_text(description, 0x15))
    assert isinstance(database, cantools.database.can.Database)
    decoded = database.get_message_by_frame_id(led_frame.can_id).decode(led_frame.data)
    assert isinstance(decoded, dict)
    assert [signal for signal, value in decoded.items() if value] == [f"green_{last}"]
    assert f"green_{last + 1}" not in decoded  # padding bits are no LED
