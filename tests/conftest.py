"""Shared test helpers: frames from the manuals' notation, and trace replay; and the suite's
check that every python-can bus a test made was shut down."""

from __future__ import annotations

import gc
import logging

import pytest

from blinkcan.protocol import Frame


def frame(text: str) -> Frame:
    """``"615 40 00 20 01 00 00 00 00"`` as the manuals print it (ids in hex)."""
    ident, *data = text.split()
    return Frame(int(ident, 16), bytes(int(b, 16) for b in data), extended=len(ident) > 3)


def frames(*texts: str) -> list[Frame]:
    return [frame(t) for t in texts]


# -- buses never shut down fail the suite ------------------------------------------------------

#: what python-can logs (a log record, not a warning: filterwarnings cannot see it) when a bus
#: is collected without shutdown(): a test that leaks its bus (its reader, its notifier)
UNSHUT = "was not properly shut down"


class UnshutBuses(logging.Handler):
    """Notes every bus collected without ``shutdown()``, with the test that ran meanwhile (a
    bus in a reference cycle is collected when the garbage collector next runs: the test that
    made it is that one or an earlier one)."""

    def __init__(self) -> None:
        super().__init__(logging.WARNING)
        self.running = "collection"
        self.seen: list[str] = []

    def emit(self, record: logging.LogRecord) -> None:
        message = record.getMessage()
        if UNSHUT in message:
            self.seen.append(f"{message} (collected during {self.running})")


UNSHUT_BUSES = pytest.StashKey[UnshutBuses]()


def pytest_configure(config: pytest.Config) -> None:
    watch = config.stash[UNSHUT_BUSES] = UnshutBuses()
    logging.getLogger("can.bus").addHandler(watch)


def pytest_runtest_setup(item: pytest.Item) -> None:
    item.config.stash[UNSHUT_BUSES].running = item.nodeid


@pytest.hookimpl(tryfirst=True)
def pytest_sessionfinish(session: pytest.Session) -> None:
    """Collect what is left, then fail the run if a bus was never shut down (python-can
    printed that after the run, where nobody looked)."""
    watch = session.config.stash[UNSHUT_BUSES]
    gc.collect()
    logging.getLogger("can.bus").removeHandler(watch)
    if watch.seen:
        reporter = session.config.pluginmanager.get_plugin("terminalreporter")
        if reporter is not None:
            reporter.ensure_newline()
            reporter.write_line(f"{len(watch.seen)} python-can buses never shut down:", red=True)
            for line in watch.seen:
                reporter.write_line(f"  {line}", red=True)
        session.exitstatus = pytest.ExitCode.TESTS_FAILED
