"""Pure frame -> meaning decoding from the device descriptions."""

from blinkcan.decode.describe import FrameDescriber, bit_list

__all__ = ["FrameDescriber", "bit_list"]
