"""A sign-magnitude signal (the PKP-3500-MT encoders' direction counter, MT §12/§13: X = 1
counterclockwise, YYYYYYY = ticks) decodes in cantools, with the DBC we write, to what the
manual says and what blinkcan's own decoder says: "81 FF FF 00 ..." is 1 tick
counterclockwise, not 129. Registry-driven: every model with such a signal."""

from __future__ import annotations

from typing import Any

import cantools
import pytest

from blinkcan.devices.pdo import PdoLayout, PdoSignal
from blinkcan.devices.registry import default_descriptions
from blinkcan.formats.dbc import dbc_text

#: (model, generation, PDO layout, its sign-magnitude signal) of every registered model
SIGNED = [(d.model, d.generation, layout, signal)
          for d in default_descriptions() for layout in d.pdos for signal in layout.signals
          if signal.sign_magnitude]


def test_some_registered_model_has_a_sign_magnitude_signal() -> None:
    assert SIGNED  # the PKP-3500-MT's encoders: else this suite tests nothing


@pytest.mark.parametrize(("model", "generation", "layout", "signal"), SIGNED,
                         ids=[f"{m}@{g}-{lay.name}" for m, g, lay, _ in SIGNED])
@pytest.mark.parametrize("raw", [0x00, 0x01, 0x03, 0x7F, 0x80, 0x81, 0x83, 0xFF])
def test_cantools_reads_the_sign_and_the_ticks(model: str, generation: str, layout: PdoLayout,
                                               signal: PdoSignal, raw: int) -> None:
    description = next(d for d in default_descriptions()
                       if (d.model, d.generation) == (model, generation))
    db: Any = cantools.database.load_string(dbc_text(description), "dbc")
    message = db.get_message_by_frame_id(layout.cob_id(description.default_node_id))
    data = (raw << signal.start).to_bytes(layout.length, "little")
    decoded = message.decode(data, decode_choices=False)
    signed = signal.physical(raw)  # what blinkcan's decoder says
    assert decoded[signal.name] == abs(signed)
    assert decoded[f"{signal.name}_counterclockwise"] == (1 if raw & 0x80 else 0)
    named = message.decode(data)[f"{signal.name}_counterclockwise"]
    assert str(named) == ("counterclockwise" if raw & 0x80 else "clockwise")


def test_the_manuals_first_encoder_example() -> None:
    """MT §12: 295h 81 FF FF 00 00 00 00 00 is "1 tick CCW"."""
    description = next(d for d in default_descriptions() if d.model == "pkp-3500-mt")
    db: Any = cantools.database.load_string(dbc_text(description), "dbc")
    decoded = db.decode_message(0x295, bytes.fromhex("81FFFF0000000000"))
    assert decoded["direction"] == 1
    assert str(decoded["direction_counterclockwise"]) == "counterclockwise"
    assert decoded["ticks"] == 0xFFFF
