"""``decode --json``'s writers (Decoder.json_rest: a device's PDO or heartbeat line written
from its data, without an Event) write exactly the line the Event's ``to_json`` makes, and
``decode``'s (Decoder.text: a PDO's text without an Event) exactly ``str(event)``, for any
data of every registered model's layouts, at every generation (issue 22)."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from blinkcan.decode import Decoder
from blinkcan.decode.decoder import encode_json
from blinkcan.devices.registry import describe_device, models
from blinkcan.protocol import Frame
from blinkcan.protocol.cob import HEARTBEAT

_SPECS = [f"{m.name}@{generation}" for m in models() for generation in m.generations]
#: heartbeat data: boot-up (forgets the keys held), the states, and anything else
_HEARTBEATS = st.one_of(st.sampled_from([b"\x00", b"\x05", b"\x7f", b"\x04", b""]),
                        st.binary(max_size=8))


@pytest.mark.parametrize("spec", _SPECS)
@settings(max_examples=40, deadline=None)
@given(data=st.data())
def test_written_lines_are_the_events_json(spec: str, data: st.DataObject) -> None:
    description = describe_device(spec)
    node = description.default_node_id
    ids = [layout.cob_id(node) for layout in description.pdos]
    frames = data.draw(st.lists(st.one_of(
        st.builds(Frame, st.sampled_from(ids), st.binary(max_size=8)),
        st.builds(Frame, st.just(HEARTBEAT + node), _HEARTBEATS)), min_size=1, max_size=40))
    fast, text, plain = Decoder({node: spec}), Decoder({node: spec}), Decoder({node: spec})
    for n, item in enumerate(frames * 2):  # twice: a pure PDO's line kept by its data
        time = 1_700_000_000 + n / 1000
        event = plain.decode(item, time)
        assert fast.json_line(item, time) == encode_json(event.to_json())
        assert text.text(item, time) == str(event)


@pytest.mark.parametrize("spec", _SPECS)
def test_every_layouts_frames_are_written_without_an_event(spec: str) -> None:
    """Once routed, a device's PDO and heartbeat lines come from json_rest (no Event): the
    comparison above is then the writers' against the Event's."""
    description = describe_device(spec)
    node = description.default_node_id
    decoder = Decoder({node: spec})
    for can_id in [layout.cob_id(node) for layout in description.pdos] + [HEARTBEAT + node]:
        decoder.json_line(Frame(can_id, bytes(8)), 1.0)
        for data in (bytes(8), b"\x01", b"\xff" * 8):
            assert decoder.json_rest(can_id, False, data, 2.0) is not None
