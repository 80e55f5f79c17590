"""The one root of blinkcan's errors: ``except blinkcan.BlinkcanError`` catches every error
blinkcan raises on its own account (as python-can's ``CanError`` and cantools' ``Error``).

Errors callers already catch by a built-in class keep it as a second base (``NvmError`` is a
``ValueError`` too), so both ``except`` clauses work. Imports nothing: every layer may use it.
"""

from __future__ import annotations


class BlinkcanError(Exception):
    """Base class of every error blinkcan defines."""


class NvmError(BlinkcanError, ValueError):
    """A twin's non-volatile memory that cannot be used (a file: the message names it).

    Here, below every layer, because the pure twin raises and catches it around any store
    (``blinkcan.twin.nvm``) and the file store that raises it lives in ``blinkcan.formats``."""
