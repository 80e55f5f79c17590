"""The pytest plugin (entry point ``pytest11``): fixtures for testing a controller on twins.

Fixtures:
- ``rig``: a :class:`~blinkcan.testing.Rig` in simulated time, closed after the test.
- ``keypad_twin``: a PKP-2600-SI twin on the rig at node 15h, startup show off (so the LEDs
  show what the controller commanded from the start).
- ``keybox_twin``: a Keybox twin on the rig at node 0Ch.

Marker: ``@pytest.mark.blinkcan(model="pkp-3500-mt", manual="1.5", protocol="j1939",
quirks="cia301", keypad_node=0x15, keybox_node=0x0C, startup_show=False)`` chooses the twins a
test gets: ``model`` is any registered keypad model (``blinkcan export --help`` lists them),
``manual`` its firmware generation, ``protocol`` one its description declares. A name the marker
does not know is a usage error naming the ones it does. A marker is checked before every test
that carries it, whatever fixtures the test uses: a bad one (``model="nope"``, an option it
does not take) fails that test with one line saying why, never passes unnoticed.

An exception raised in a test's handlers (key, fault, health callbacks) or in work handed to
``host.spawn`` fails that test with its traceback: it is raised from the rig or driver call that
ran the simulation, or at the ``rig`` fixture's teardown (``Rig.close``).

Golden traces: ``assert_matches_trace(rig.frames, path)``; run pytest with
``--blinkcan-record`` to (re)write the traces instead of comparing (``golden_trace`` fixture).

A test on the ``rig`` fixture never hangs: one still running after ``--blinkcan-wall-limit``
real seconds (ini ``blinkcan_wall_limit``; default 60, 0: none) fails, saying the virtual time
it reached. Only the simulation moves a rig's clock, so a test that waits in real time for what
only the simulation brings (an ``asyncio.Event`` or a queue a handler feeds, a thread of its
own, ``time.sleep`` in a handler) would otherwise wait for ever. The limit is an alarm signal
(SIGALRM) in pytest's main thread, so it interrupts any blocking wait there; it is left off
where that signal already has a handler (another plugin's timeout, the test's own).
"""

from __future__ import annotations

import contextlib
import signal
import threading
from collections.abc import Callable, Iterator
from pathlib import Path
from types import FrameType
from typing import Any

import pytest

from blinkcan.devices.keypad import SHOW_OFF
from blinkcan.testing.golden import assert_matches_trace, record_trace
from blinkcan.testing.rig import Rig
from blinkcan.twin import KeyboxTwin, KeypadTwin

#: real seconds a test on the ``rig`` fixture may run (its simulation takes milliseconds)
WALL_LIMIT = 60.0


def pytest_addoption(parser: pytest.Parser) -> None:
    parser.addoption("--blinkcan-record", action="store_true", default=False,
                     help="blinkcan: write golden traces instead of comparing with them")
    parser.addoption("--blinkcan-wall-limit", type=float, default=None, metavar="SECONDS",
                     help="blinkcan: real seconds a test on the rig fixture may run before "
                          f"it fails (default {WALL_LIMIT:g}; 0: no limit)")
    parser.addini("blinkcan_wall_limit", f"blinkcan: real seconds a test on the rig fixture "
                  f"may run (default {WALL_LIMIT:g}; 0: no limit)", default=str(WALL_LIMIT))


MARKER_OPTIONS = ("model", "manual", "protocol", "quirks", "keypad_node", "keybox_node",
                  "startup_show")


def pytest_configure(config: pytest.Config) -> None:
    _wall_limit(config)  # a wrong limit is a usage error before any test runs
    config.addinivalue_line(
        "markers", f"blinkcan({', '.join(MARKER_OPTIONS)}): the twins the blinkcan fixtures build")


def _options(node: pytest.Item | pytest.FixtureRequest) -> dict[str, Any]:
    item = node.node if isinstance(node, pytest.FixtureRequest) else node
    marker = item.get_closest_marker("blinkcan")
    options = dict(marker.kwargs) if marker is not None else {}
    unknown = sorted(set(options) - set(MARKER_OPTIONS))
    if unknown:
        raise pytest.UsageError(f"@pytest.mark.blinkcan does not take {', '.join(unknown)}: "
                                f"it takes {', '.join(MARKER_OPTIONS)}")
    if marker is not None and marker.args:
        names = ", ".join(MARKER_OPTIONS)
        raise pytest.UsageError(f"@pytest.mark.blinkcan takes names only ({names}=...), "
                                f"not {marker.args!r}")
    return options


def _keypad_twin(options: dict[str, Any]) -> KeypadTwin:
    """The keypad twin the marker's ``options`` ask for (the twin checks its arguments)."""
    settings = {} if options.get("startup_show", False) else {"startup_led_show": SHOW_OFF}
    return KeypadTwin(node_id=options.get("keypad_node", 0x15),
                      quirks=options.get("quirks", "firmware"),
                      manual=options.get("manual"), protocol=options.get("protocol", "canopen"),
                      model=options.get("model"), settings=settings)


def _keybox_twin(options: dict[str, Any]) -> KeyboxTwin:
    return KeyboxTwin(node_id=options.get("keybox_node", 0x0C),
                      quirks=options.get("quirks", "firmware"))


@pytest.hookimpl(tryfirst=True)
def pytest_runtest_setup(item: pytest.Item) -> None:
    """A test with a ``blinkcan`` marker: the twins it names are built once to check it, so
    that a bad marker fails the test whatever fixtures it uses (a test that takes ``rig``
    only would otherwise never see ``model="nope"``)."""
    if item.get_closest_marker("blinkcan") is None:
        return
    try:
        options = _options(item)
        if not isinstance(options.get("startup_show", False), bool):
            raise TypeError(f"startup_show is True or False, not {options['startup_show']!r}")
        _keypad_twin(options)
        _keybox_twin(options)
    except (pytest.UsageError, ValueError, TypeError) as error:
        wrong = str(error).removeprefix("@pytest.mark.blinkcan ")
    else:
        return
    pytest.fail(f"@pytest.mark.blinkcan: {wrong}", pytrace=False)  # one line, no traceback


def _wall_limit(config: pytest.Config) -> float:
    """The ``--blinkcan-wall-limit`` (or ini ``blinkcan_wall_limit``) in seconds; a usage
    error naming the option for anything but a finite number >= 0."""
    given = config.getoption("--blinkcan-wall-limit")
    text = str(config.getini("blinkcan_wall_limit")) if given is None else str(given)
    try:
        seconds = float(text)
    except ValueError:
        seconds = -1.0
    if not 0 <= seconds < float("inf"):
        raise pytest.UsageError(f"--blinkcan-wall-limit / blinkcan_wall_limit: seconds >= 0 "
                                f"(0: no limit), not {text!r}")
    return seconds


@contextlib.contextmanager
def _failing_after(seconds: float, bench: Rig) -> Iterator[None]:
    """Fail the running test after ``seconds`` real seconds (SIGALRM: it interrupts a wait in
    pytest's main thread); nothing where that cannot be done or a handler is already set."""
    if (seconds <= 0 or not hasattr(signal, "setitimer")
            or threading.current_thread() is not threading.main_thread()
            or signal.getsignal(signal.SIGALRM) not in (signal.SIG_DFL, None)):
        yield
        return

    #: the virtual time at half the limit: whether the simulation still moves tells a loop
    #: that runs it for ever from a wait in real time that nothing runs it for
    halfway: list[float] = []

    def expired(signum: int, frame: FrameType | None) -> None:
        if not halfway:
            halfway.append(bench.now)
            signal.setitimer(signal.ITIMER_REAL, seconds / 2)
            return
        # pytest.fail raises an OutcomeException (a BaseException): no `except Exception` in
        # the test, a handler or the simulation takes it for an error of theirs
        if bench.now > halfway[0]:
            pytest.fail(f"blinkcan: the test still ran after {seconds:g} s of wall time, and "
                        f"the simulation ran on (virtual t={halfway[0]:.3f} s halfway, "
                        f"{bench.now:.3f} s now): a loop that never meets its end, such as a "
                        "`while` around rig.advance whose condition never comes true, or "
                        "work that keeps making more work; --blinkcan-wall-limit changes the "
                        "limit", pytrace=True)
        pytest.fail(f"blinkcan: the test still ran after {seconds:g} s of wall time, at virtual "
                    f"t={bench.now:.3f} s: something waits in real time for what only the "
                    "simulation brings (an asyncio.Event or a queue fed by a handler, a thread "
                    "of its own, time.sleep in a handler), and nothing runs the simulation "
                    "meanwhile (rig.advance / rig.until, a driver call, a blocking iterator); "
                    "--blinkcan-wall-limit changes the limit", pytrace=True)

    previous = signal.signal(signal.SIGALRM, expired)
    signal.setitimer(signal.ITIMER_REAL, seconds / 2)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


@pytest.fixture
def rig(request: pytest.FixtureRequest) -> Iterator[Rig]:
    """Twins and drivers on one simulated bus, at virtual time 0; the test fails (never hangs)
    after ``--blinkcan-wall-limit`` real seconds."""
    with Rig() as bench, _failing_after(_wall_limit(request.config), bench):
        yield bench


@pytest.fixture
def keypad_twin(rig: Rig, request: pytest.FixtureRequest) -> KeypadTwin:
    """A keypad twin on the rig, at node 15h, its start-up show off (the LEDs show what the
    controller commands from the start). The ``blinkcan`` marker picks the model (default the
    PKP-2600-SI), its generation (``manual``), ``protocol``, ``quirks``, ``keypad_node`` and
    ``startup_show=True``."""
    return rig.add(_keypad_twin(_options(request)))


@pytest.fixture
def keybox_twin(rig: Rig, request: pytest.FixtureRequest) -> KeyboxTwin:
    """A Keybox twin on the rig, at node 0Ch (the ``blinkcan`` marker's ``keybox_node`` and
    ``quirks`` change it)."""
    return rig.add(_keybox_twin(_options(request)))


@pytest.fixture
def golden_trace(request: pytest.FixtureRequest) -> Callable[..., None]:
    """``golden_trace(rig.frames, "traces/watchdog.log")``: compare with the file (a path
    relative to the test file), or write it when pytest runs with ``--blinkcan-record``."""
    recording = bool(request.config.getoption("--blinkcan-record"))
    here = Path(request.node.path).parent

    def check(frames: Any, path: str, tolerance: float = 0.001) -> None:
        target = here / path
        if recording:
            target.parent.mkdir(parents=True, exist_ok=True)
            record_trace(frames, target, replace=True)
        elif not target.exists():
            raise AssertionError(f"no golden trace {target} yet: run pytest with "
                                 "--blinkcan-record to write it from this run")
        else:
            assert_matches_trace(frames, target, tolerance)

    return check
