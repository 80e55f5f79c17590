"""Work handed to SimulatedScheduler.spawn runs one piece at a time, never one inside another.

A piece of work that waits (a driver's blocking call) runs the simulation; a periodic timer
firing meanwhile spawns more. Run inside the first one's wait, each new piece started its own
wait one period later, so the caller's ``until`` was never looked at again: virtual time ran
away to a RecursionError (t=10.85 s for ``run_until(None, 0.1)``; found by hatk10 with a
Keybox's fault poll on a powered-off Keybox).
"""

from __future__ import annotations

import functools
import itertools

from blinkcan.runtime.scheduler import SimulatedScheduler

PERIOD = 0.05
WAIT = 1.0


def _polling() -> tuple[SimulatedScheduler, list[float], list[int]]:
    """A scheduler whose timer spawns, every PERIOD, work that waits WAIT for nothing; and
    the start times of the work and the nesting seen at each start."""
    scheduler = SimulatedScheduler()
    starts: list[float] = []
    nesting: list[int] = []
    running = [0]

    def poll() -> None:
        running[0] += 1
        nesting.append(running[0])
        starts.append(scheduler.now)
        try:
            scheduler.wait(scheduler.signal(), WAIT, background=True)
        finally:
            running[0] -= 1

    scheduler.call_every(PERIOD, lambda: scheduler.spawn(poll))
    return scheduler, starts, nesting


def test_a_run_ends_after_the_work_running_at_its_end() -> None:
    scheduler, starts, nesting = _polling()
    scheduler.run_until(None, 0.1)
    assert scheduler.now <= 0.1 + WAIT  # the one piece running at 0.1 ends its wait, no more
    assert starts == [0.0]
    assert nesting == [1]


def test_spawned_work_runs_one_piece_at_a_time_in_order() -> None:
    scheduler, starts, nesting = _polling()
    for end in (0.5, 2.0, 4.0):
        scheduler.run_until(None, end)
        assert scheduler.now <= end + WAIT
    assert set(nesting) == {1}
    assert starts == sorted(starts)
    assert all(later - earlier >= WAIT for earlier, later in itertools.pairwise(starts))


def test_work_spawned_before_runs_in_the_order_it_was_handed_over() -> None:
    scheduler = SimulatedScheduler()
    ran: list[str] = []
    for name in "abc":
        scheduler.spawn(functools.partial(ran.append, name))
    scheduler.spawn(lambda: ran.append("keyed"), key="k")
    scheduler.spawn(lambda: ran.append("keyed again"), key="k")  # one pending per key
    scheduler.run_until(None, 0.0)
    assert ran == ["a", "b", "c", "keyed"]
