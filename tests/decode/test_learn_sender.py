"""A node's model learned from a PDO only that model sends (devices/registry.py sole_senders),
as from identity: in a capture that starts mid-stream (no identity traffic), once such a frame
is seen every frame decodes as with the model named; the frames before keep what they meant."""

from __future__ import annotations

from collections.abc import Callable

import pytest

from blinkcan.decode import Decoder
from blinkcan.devices.model import DeviceDescription, Model
from blinkcan.devices.pdo import Direction
from blinkcan.devices.registry import default_descriptions, describe_device, models, sole_senders
from blinkcan.protocol import Frame

#: the devices decode assumes without --device (cli/decode.py DEFAULT_DEVICES)
_ASSUMED = ("keypad", "keybox")


def _assumed() -> dict[int, DeviceDescription]:
    return {d.default_node_id: d for d in map(describe_device, _ASSUMED)}


def _traffic(description: DeviceDescription, node: int) -> list[Frame]:
    """A frame of each of the model's PDOs, twice with other bytes (keys, LEDs, values)."""
    return [Frame(layout.cob_id(node), bytes((fill,) * layout.length))
            for fill in (0x00, 0x21, 0x00) for layout in description.pdos]


def test_every_sole_sender_is_the_one_model_using_its_identifier_and_sends_it() -> None:
    """Registry-driven: a base names a model only where that model transmits it and no
    other registered model's PDO uses it; every such base is listed."""
    users: dict[int, set[str]] = {}
    for description in default_descriptions():
        for layout in description.pdos:
            users.setdefault(layout.cob_base, set()).add(description.model)
    for description in default_descriptions():
        for layout in description.pdos:
            sole = users[layout.cob_base] == {description.model}
            if layout.direction is Direction.TX and sole:
                assert sole_senders()[layout.cob_base].model == description.model
            elif not sole:
                assert layout.cob_base not in sole_senders()
    for base, sender in sole_senders().items():
        assert any(p.cob_base == base and p.direction is Direction.TX for p in sender.pdos)


@pytest.mark.parametrize("model", models(), ids=lambda model: model.name)
@pytest.mark.parametrize("assumed", [True, False], ids=["assumed", "unknown"])
def test_a_mid_stream_capture_learns_the_model_from_a_frame_only_it_sends(
        model: Model, assumed: bool) -> None:
    """At the model's own node with the defaults assumed there, and at a node no device is
    assumed at: after the distinguishing frame every frame decodes as with --device; before
    it, as without learning."""
    node = model.default_node_id if assumed else 0x3A
    description = describe_device(model.name)
    assumed_devices = _assumed() if assumed else {}
    traffic = [_heartbeat(node), *_traffic(description, node)]
    teaching = [n for n, frame in enumerate(traffic)
                if sole_senders().get(frame.can_id - node) is not None
                and sole_senders()[frame.can_id - node].model == model.name]
    learning = Decoder(assumed_devices, assumed=True)
    events = [learning.decode(frame, n * 0.01) for n, frame in enumerate(traffic)]
    if not teaching:  # no frame of its own: nothing learned, nothing changed
        assert learning.devices == assumed_devices
        return
    first = teaching[0]
    named = Decoder({**assumed_devices, node: description})
    unlearned = Decoder(assumed_devices, learn=False)
    expected = [named.decode(frame, n * 0.01) for n, frame in enumerate(traffic)]
    before = [unlearned.decode(frame, n * 0.01) for n, frame in enumerate(traffic[:first])]
    assert events[:first] == before
    assert events[first:] == expected[first:]
    assert learning.devices[node].model == model.name
    assert [learning.json_line(f, 9.0) for f in traffic] == \
        [named.json_line(f, 9.0) for f in traffic]


def _heartbeat(node: int) -> Frame:
    return Frame(0x700 + node, b"\x05")  # CiA 301 §7.2.8.3: operational


@pytest.mark.parametrize("model", models(), ids=lambda model: model.name)
def test_another_ecus_frame_on_a_sole_senders_identifier_makes_no_device_up(
        model: Model) -> None:
    """Other ECUs' 11-bit frames use the PDO identifiers too (the realistic log's made up 14
    PKP-3500-MTs and decoded their frames as knob turns): at a node nobody assumed, a model
    is named only once the node is heard as a CANopen node, and from then on."""
    node = 0x3A
    description = describe_device(model.name)
    traffic = _traffic(description, node)
    if not any(getattr(sole_senders().get(f.can_id - node), "model", None) == model.name
               for f in traffic):
        pytest.skip(f"{model.name} sends no frame only it sends")
    decoder = Decoder({}, assumed=True)
    unlearned = Decoder({}, learn=False)
    for n, frame in enumerate(traffic):
        assert decoder.decode(frame, n * 0.01) == unlearned.decode(frame, n * 0.01)
        assert decoder.json_line(frame, n * 0.01) == unlearned.json_line(frame, n * 0.01)
    assert node not in decoder.devices
    decoder.decode(_heartbeat(node), 1.0)
    assert decoder.devices[node].model == model.name
    named = Decoder({node: description})
    named.decode(_heartbeat(node), 1.0)
    for frame in traffic:
        assert decoder.json_line(frame, 2.0) == named.json_line(frame, 2.0)


def test_a_node_named_by_the_caller_is_never_relearned() -> None:
    """--device names the node: a frame of another model's keeps the model given."""
    keypad = describe_device("keypad")
    frames = [Frame(base + 0x15, bytes(8)) for base in sole_senders()]
    assert frames
    decoder = Decoder({0x15: keypad})
    for frame in frames:
        decoder.decode(frame)
    assert decoder.devices[0x15] is keypad


#: frames that show a CANopen node is at ``node`` (Decoder._hear), by what they are
_SHOWN_BY: dict[str, Callable[[int], Frame]] = {
    "its heartbeat": _heartbeat,
    "its SDO reply": lambda node: Frame(0x580 + node, bytes((0x60, 0x17, 0x10, 0, 0, 0, 0, 0))),
    "an NMT start addressed to it": lambda node: Frame(0x000, bytes((0x01, node))),
}
#: frames that do not: an NMT command to all nodes, a request nobody answered
_NOT_SHOWN_BY: dict[str, Callable[[int], Frame]] = {
    "an NMT start to all nodes": lambda node: Frame(0x000, bytes((0x01, 0))),
    "an SDO request to it": lambda node: Frame(0x600 + node, bytes((0x40, 0, 0x10, 0, 0, 0, 0, 0))),
}
#: registered models with a frame only they send (the PKP-3500-MT's encoder and analog TPDOs)
_SOLE_SENDING = [m for m in models() if any(
    sender.model == m.name for sender in sole_senders().values())]


@pytest.mark.parametrize("json", [False, True], ids=["events", "json"])
@pytest.mark.parametrize("evidence", [*_SHOWN_BY, *_NOT_SHOWN_BY])
@pytest.mark.parametrize("model", _SOLE_SENDING, ids=lambda model: model.name)
def test_a_node_shown_to_be_canopen_names_the_model_of_its_sole_sender_frames(
        model: Model, evidence: str, json: bool) -> None:
    """A PKP-3500-MT at a node nobody assumed, with its heartbeat off (its default), is named
    from its own frames once an SDO reply comes from it or the master addresses it an NMT
    command, as by a heartbeat (found by the newcomer pass: `monitor` of an MT at 16h showed
    raw frames after `nmt start 0x16`); a broadcast NMT or an unanswered request does not."""
    node = 0x16
    description = describe_device(model.name)
    traffic = _traffic(description, node)
    decoder = Decoder({}, assumed=True)
    frames = [*traffic, {**_SHOWN_BY, **_NOT_SHOWN_BY}[evidence](node)]
    for n, frame in enumerate(frames):
        if json:
            decoder.json_line(frame, n * 0.01)
        else:
            decoder.decode(frame, n * 0.01)
    if evidence in _SHOWN_BY:
        assert decoder.devices[node].model == model.name
        same_as = Decoder({node: description})
    else:
        assert node not in decoder.devices
        same_as = Decoder({}, learn=False)
    for frame in traffic:
        assert decoder.json_line(frame, 2.0) == same_as.json_line(frame, 2.0)
