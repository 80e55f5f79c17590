"""blinkcan: digital twins, host drivers and decoders for Blink Marine CANopen devices.

The PKP-2600-SI and PKP-3500-MT keypads and the Keybox power module, on any python-can bus. The
pure core (``protocol``, ``devices``, ``twin``) does no I/O and imports without python-can;
``runtime`` puts twins on a bus. The drivers below are imported on first use (PEP 562), so
``import blinkcan.twin`` does not pull in python-can or threads.
"""

from __future__ import annotations

from importlib import import_module

from blinkcan.errors import BlinkcanError

#: typing is not imported: its import is the most of this package's (tens of milliseconds),
#: before the command line's Ctrl-C handler is in place (cli/entry.py)
TYPE_CHECKING = False
if TYPE_CHECKING:
    from typing import Any

    from blinkcan.host import Keybox, Keypad, scan
    from blinkcan.protocol import Frame

__all__ = ["BlinkcanError", "Frame", "Keybox", "Keypad", "__version__", "scan"]
__version__ = "0.1.0"

#: public name -> the module that defines it, imported when the name is first used
_LAZY = {"Frame": "blinkcan.protocol", "Keybox": "blinkcan.host", "Keypad": "blinkcan.host",
         "scan": "blinkcan.host"}


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'blinkcan' has no attribute {name!r}")
    return getattr(import_module(module), name)


def __dir__() -> list[str]:
    return sorted(__all__)
