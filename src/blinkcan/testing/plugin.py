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
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

from blinkcan.devices.keypad import SHOW_OFF
from blinkcan.testing.golden import assert_matches_trace, record_trace
from blinkcan.testing.rig import Rig
from blinkcan.twin import KeyboxTwin, KeypadTwin


def pytest_addoption(parser: pytest.Parser) -> None:
    parser.addoption("--blinkcan-record", action="store_true", default=False,
                     help="blinkcan: write golden traces instead of comparing with them")


MARKER_OPTIONS = ("model", "manual", "protocol", "quirks", "keypad_node", "keybox_node",
                  "startup_show")


def pytest_configure(config: pytest.Config) -> None:
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


@pytest.fixture
def rig() -> Iterator[Rig]:
    """Twins and drivers on one simulated bus, at virtual time 0."""
    with Rig() as bench:
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
