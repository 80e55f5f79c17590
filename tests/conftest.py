"""Shared test helpers: frames from the manuals' notation, and trace replay."""

from __future__ import annotations

from blinkcan.protocol import Frame


def frame(text: str) -> Frame:
    """``"615 40 00 20 01 00 00 00 00"`` as the manuals print it (ids in hex)."""
    ident, *data = text.split()
    return Frame(int(ident, 16), bytes(int(b, 16) for b in data), extended=len(ident) > 3)


def frames(*texts: str) -> list[Frame]:
    return [frame(t) for t in texts]
