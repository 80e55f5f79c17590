"""The command line's entry point (the ``blinkcan`` script and ``python -m blinkcan``): Ctrl-C
while the rest loads (click, rich, python-can: a few tenths of a second) says ``interrupted``
and exits 130, as it does once a command runs (cli/main.py), instead of a traceback of
whatever import it hit. So this module imports nothing before the handler is in place but
what the interpreter has loaded already (``os``, ``sys``) and ``_signal``, the built-in
module under ``signal`` (whose own import, with ``enum``, is a window of its own).
What runs before this module (the interpreter's start-up, ``site``, runpy finding
``blinkcan``) is out of its reach. A Ctrl-C that lands in a callback whose exceptions the
interpreter drops (an import's module-lock callback: the first lazy imports of any command) is
raised again where the command catches it, not printed as "Exception ignored" and lost."""

from __future__ import annotations

import _signal  # type: ignore[import-not-found]  # see the module docstring (no stubs)
import _thread  # built in and loaded at start-up (importlib's locks): no window
import os
import sys

TYPE_CHECKING = False  # typing's import is a window too (tens of milliseconds)
if TYPE_CHECKING:
    from sys import UnraisableHookArgs
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


def _interrupt_main_soon() -> None:
    """From a thread of its own, a moment later: SIGINT's handler runs again in the main
    thread, out of the callback (from the hook itself it ran in the hook, and was dropped)."""
    import time  # noqa: PLC0415 (here only: this module imports nothing before its handler)

    time.sleep(0.001)
    _thread.interrupt_main()


def keep_interrupts_from_callbacks() -> None:
    """A KeyboardInterrupt raised in a callback whose exceptions the interpreter ignores (the
    weak-reference callback that frees an import's module lock, a ``__del__``) was printed as
    "Exception ignored in ..." with a traceback, then dropped: the command ran on. Hand it to
    the main thread again a moment later (the SIGINT handler runs then, in the command's code,
    where the command line catches it); any other such exception goes to the hook before."""
    before = sys.unraisablehook

    def hook(unraisable: UnraisableHookArgs) -> None:
        if unraisable.exc_type is not None and issubclass(unraisable.exc_type,
                                                          KeyboardInterrupt):
            _thread.start_new_thread(_interrupt_main_soon, ())
            return
        before(unraisable)

    sys.unraisablehook = hook


def main() -> None:
    """Run the command line, Ctrl-C quiet from the first moment to the last."""
    keep_interrupts_from_callbacks()
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
