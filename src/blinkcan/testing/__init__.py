"""Test your controller against the twins, in simulated time.

``Rig`` puts twins and your drivers on one simulated bus; ``golden`` compares a run's frames
with a recorded trace; the pytest plugin (installed with blinkcan) gives fixtures ``rig``,
``keypad_twin`` and ``keybox_twin`` and the marker ``@pytest.mark.blinkcan(...)``.
"""

from blinkcan.runtime.simbus import TimedFrame
from blinkcan.testing.golden import assert_matches_trace, record_trace
from blinkcan.testing.rig import Rig, WrongThreadError, frames_of

__all__ = ["Rig", "TimedFrame", "WrongThreadError", "assert_matches_trace", "frames_of",
           "record_trace"]
