"""The real-time scheduler's loop: one call at a time and in order, whichever thread runs it
(a reader delivering a frame while the loop is idle runs it on its own thread), and the
signal its waits use."""

from __future__ import annotations

import threading

from blinkcan.runtime.scheduler import RealTimeScheduler, Wakeup


def test_a_frame_delivered_while_the_loop_is_idle_runs_at_once_in_the_loop() -> None:
    scheduler = RealTimeScheduler("test")
    scheduler.start()
    try:
        seen: list[tuple[str, bool]] = []
        scheduler.run(lambda: None)  # the loop is up and idle
        scheduler.deliver(lambda name: seen.append((name, scheduler.in_loop)), "frame")
        assert seen == [("frame", True)]  # ran before deliver returned, as the loop's work
        assert not scheduler.in_loop  # and the loop was handed back
    finally:
        scheduler.stop()


def test_a_frame_delivered_after_a_posted_call_runs_after_it() -> None:
    scheduler = RealTimeScheduler("test")
    scheduler.start()
    try:
        order: list[str] = []
        release = threading.Event()
        scheduler.post(lambda: release.wait(2))  # the loop is busy
        scheduler.post(lambda: order.append("posted"))
        scheduler.deliver(order.append, "delivered")
        release.set()
        scheduler.run(lambda: None)
        assert order == ["posted", "delivered"]
    finally:
        scheduler.stop()


def test_a_deliverer_bound_before_the_loop_starts_delivers_as_deliver_does() -> None:
    """What a port calls per frame (bound once, when a receiver starts listening): posted
    while the loop is not running, at once as the loop's work when it is idle, after a
    posted call while one waits."""
    scheduler = RealTimeScheduler("test")
    seen: list[tuple[str, bool]] = []
    deliver = scheduler.deliverer(lambda name: seen.append((name, scheduler.in_loop)))
    deliver("before start")
    assert seen == []  # no loop yet: posted
    scheduler.start()
    try:
        scheduler.run(lambda: None)
        assert seen == [("before start", True)]
        deliver("idle")
        assert seen[-1] == ("idle", True)  # ran before it returned
        release = threading.Event()
        scheduler.post(lambda: release.wait(2))  # the loop is busy
        scheduler.post(lambda: seen.append(("posted", scheduler.in_loop)))
        deliver("busy")
        release.set()
        scheduler.run(lambda: None)
        assert seen[-2:] == [("posted", True), ("busy", True)]
    finally:
        scheduler.stop()


def test_loop_work_never_overlaps_between_readers_and_timers() -> None:
    scheduler = RealTimeScheduler("test")
    scheduler.start()
    busy = threading.Lock()
    overlaps: list[str] = []
    count = [0]

    def work(name: str) -> None:
        if not busy.acquire(blocking=False):
            overlaps.append(name)
            return
        try:
            assert scheduler.in_loop
            count[0] += 1
        finally:
            busy.release()

    def reader(name: str) -> None:
        for _ in range(300):
            scheduler.deliver(work, name)

    timer = scheduler.call_every(0.0005, lambda: work("timer"))
    try:
        readers = [threading.Thread(target=reader, args=(f"r{i}",)) for i in range(3)]
        for thread in readers:
            thread.start()
        for thread in readers:
            thread.join(10)
        timer.cancel()
        scheduler.run(lambda: None)  # what was posted has run
        assert overlaps == []
        assert count[0] >= 900
    finally:
        scheduler.stop()


def test_a_call_posted_to_a_stopped_loop_fails_the_caller() -> None:
    scheduler = RealTimeScheduler("test")
    scheduler.start()
    release = threading.Event()
    scheduler.post(lambda: release.wait(2))
    results: list[BaseException] = []

    def call() -> None:
        try:
            scheduler.run(lambda: None, timeout=3)
        except RuntimeError as error:
            results.append(error)

    caller = threading.Thread(target=call)
    caller.start()
    stopper = threading.Thread(target=scheduler.stop)
    stopper.start()
    release.set()
    caller.join(5)
    stopper.join(5)
    assert len(results) <= 1  # it ran before the stop, or it was failed: never left waiting
    assert not caller.is_alive()


def test_wakeup_wakes_every_waiter_and_times_out_when_not_set() -> None:
    signal = Wakeup()
    assert not signal.is_set()
    assert not signal.wait(0.01)
    assert not signal.wait(0)
    woken: list[bool] = []
    waiters = [threading.Thread(target=lambda: woken.append(signal.wait(5))) for _ in range(3)]
    for thread in waiters:
        thread.start()
    signal.set()
    signal.set()  # twice is once
    for thread in waiters:
        thread.join(5)
    assert woken == [True, True, True]
    assert signal.is_set()
    signal.clear()
    assert not signal.is_set()
    signal.clear()
    assert not signal.wait(0.01)


def test_the_scheduler_waits_on_its_signal() -> None:
    scheduler = RealTimeScheduler("test")
    signal = scheduler.signal()
    assert not scheduler.wait(signal, 0.01)
    threading.Timer(0.01, signal.set).start()
    assert scheduler.wait(signal, 5)
