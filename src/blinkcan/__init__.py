"""blinkcan: digital twins, host drivers and decoders for Blink Marine CANopen devices.

The PKP-2600-SI keypad and the Keybox power module, on any python-can bus. The pure core
(``protocol``, ``devices``, ``twin``) does no I/O; ``runtime`` puts twins on a bus.
"""

from blinkcan.host import Keybox, Keypad, scan
from blinkcan.protocol import Frame

__all__ = ["Frame", "Keybox", "Keypad", "__version__", "scan"]
__version__ = "0.1.0"
