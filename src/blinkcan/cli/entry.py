"""The command line's entry point (the ``blinkcan`` script and ``python -m blinkcan``): Ctrl-C
while the rest loads (click, rich, python-can: a few tenths of a second) says ``interrupted``
and exits 130, as it does once a command runs (cli/main.py), instead of a traceback of
whatever import it hit. So this module imports nothing before the handler is in place but
what the interpreter has loaded already (``os``, ``sys``) and ``_signal``, the built-in
module under ``signal`` (whose own import, with ``enum``, is a window of its own).
What runs before this module (the interpreter's start-up, ``site``, runpy finding
``blinkcan``) is out of its reach."""

from __future__ import annotations

import _signal  # type: ignore[import-not-found]  # see the module docstring (no stubs)
import os
import sys

TYPE_CHECKING = False  # typing's import is a window too (tens of milliseconds)
if TYPE_CHECKING:
    from types import FrameType


def _interrupted(signum: int, frame: FrameType | None) -> None:
    """Ctrl-C while nothing can catch it (the imports, the interpreter's exit): one line,
    the shell's code for SIGINT, nothing else run."""
    for stream in (sys.stdout, sys.stderr):
        try:  # noqa: SIM105 (contextlib is one more import before the handler)
            stream.flush()  # what a command printed is kept
        except (OSError, ValueError, RuntimeError):  # closed, or interrupted mid-write
            pass
    try:  # noqa: SIM105
        os.write(2, b"interrupted\n")
    except OSError:
        pass
    os._exit(130)


def main() -> None:
    """Run the command line, Ctrl-C quiet from the first moment to the last."""
    before = _signal.getsignal(_signal.SIGINT)
    quiet = before is _signal.default_int_handler  # SIGINT ignored (nohup, `&`) stays so
    if quiet:
        _signal.signal(_signal.SIGINT, _interrupted)
    from blinkcan.cli.main import main as run  # noqa: PLC0415 (after the handler)

    if quiet:  # the command's own: KeyboardInterrupt, which cli/main.py answers
        _signal.signal(_signal.SIGINT, before)
    try:
        run()
    finally:
        if quiet and _signal.getsignal(_signal.SIGINT) is _signal.default_int_handler:
            _signal.signal(_signal.SIGINT, _interrupted)  # the interpreter's exit: threads joined
