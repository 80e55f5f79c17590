"""Pure frame -> event decoding from the device descriptions."""

from blinkcan.decode.decoder import Decoder, Event, Kind
from blinkcan.decode.describers import listing, numbers

__all__ = ["Decoder", "Event", "Kind", "listing", "numbers"]
