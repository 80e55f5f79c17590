"""Every deadline a twin names is consumed when time reaches it (issue 17 item 1).

Every registered model, generation and protocol is driven through power cycles, NMT commands,
writes of its periodic settings (heartbeat, event timers, fault and analog periods, startup
show, DEMO mode, consumer heartbeat), protocol switches both ways, J1939 timers, SYNC, keys and
knobs, at random times; time then runs from deadline to deadline as the emulator runs it, and
after ``advance(t)`` at a deadline ``t`` the next one must be later than ``t``.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from blinkcan.devices.keypad_j1939 import COMMANDS_BY_NAME, PGN_COMMAND, PRIORITY
from blinkcan.devices.model import Model
from blinkcan.devices.objects import Access, DataType, ObjectEntry
from blinkcan.devices.registry import models
from blinkcan.protocol import Frame
from blinkcan.protocol.j1939 import GLOBAL_ADDRESS, compose_id
from blinkcan.protocol.sdo import EXPEDITED_DOWNLOAD_COMMAND
from blinkcan.twin.base import CanopenTwin
from blinkcan.twin.registry import build_twin
from blinkcan.twin.schedule import CATCH_UP_PERIODS, Periodic, Ticker, at

#: the stored settings that start, stop or time something (written most often)
TIMING = ("producer_heartbeat_time", "tpdo1_event_timer", "tpdo2_event_timer",
          "tpdo3_event_timer", "fault_period", "analog_period", "startup_led_show", "demo_mode",
          "consumer_heartbeat_time", "can_protocol", "tpdo1_transmission_type")
#: J1939 commands that start, stop or time something (spec/pkp-2600-si-j1939.md)
J1939_TIMING = ("heartbeat", "periodic_key_state", "key_message_period", "startup_led_show",
                "demo_mode", "address_claim", "switch_to_canopen")
HOST = 0x7F  # the node whose heartbeat a consumer watches here


def variants() -> Iterator[tuple[Model, str, str]]:
    """Every (model, generation, protocol) in the registry."""
    for model in models():
        for generation in model.generations:
            description = model.description(generation)
            yield model, generation, "canopen"
            if "j1939" in description.features:
                yield model, generation, "j1939"


VARIANTS = list(variants())
IDS = [f"{model.name}@{generation}-{protocol}" for model, generation, protocol in VARIANTS]


def build(model: Model, generation: str, protocol: str) -> CanopenTwin:
    options: dict[str, Any] = {} if protocol == "canopen" else {"protocol": protocol}
    return build_twin(f"{model.name}@{generation}", **options)


@dataclass
class Clock:
    """Runs a twin from deadline to deadline, as the emulator does, checking each one."""

    twin: CanopenTwin
    now: float = 0.0

    def run_to(self, until: float) -> None:
        for _ in range(200_000):
            deadline = self.twin.next_deadline()
            if deadline is None or deadline > until:
                break
            assert math.isfinite(deadline)
            self.now = max(self.now, deadline)  # a deadline already past runs late, at now
            self.twin.advance(self.now)
            following = self.twin.next_deadline()
            assert following is None or following > self.now, (
                f"{self.twin.snapshot()['model']}: advance({self.now!r}) left the deadline "
                f"{following!r} it named unconsumed")
        else:
            raise AssertionError(f"more than 200,000 deadlines before t={until}")
        self.now = max(self.now, until)


def sdo_write(twin: CanopenTwin, entry: ObjectEntry, value: int) -> Frame:
    size = entry.data_type.size or 4
    data = bytes((EXPEDITED_DOWNLOAD_COMMAND[size],)) + entry.mux
    return Frame(0x600 + twin.node_id, data + value.to_bytes(size, "little") + bytes(4 - size))


def value_for(entry: ObjectEntry) -> st.SearchStrategy[int]:
    if entry.name == "consumer_heartbeat_time":
        return st.builds(lambda ms: HOST << 16 | ms, st.sampled_from([0, 50, 100, 250, 1000]))
    size = entry.data_type.size or 4
    if entry.valid is None:
        return st.integers(0, min(3000, (1 << (8 * size)) - 1))
    return st.sampled_from(entry.valid.spans).flatmap(
        lambda span: st.integers(span[0], min(span[1], max(span[0], 3000))))


def operation(twin: Any) -> st.SearchStrategy[tuple[str, Callable[[float], object]]]:
    """One thing done to ``twin`` at a time, drawn; (what, action(now))."""
    description = twin.description
    writable = [e for e in description.table if e.access in (Access.RW, Access.WO)
                and e.data_type is not DataType.VISIBLE_STRING and e.name != "node_id"]
    timing = [e for e in writable if e.name in TIMING]

    def write(entry: ObjectEntry, value: int) -> tuple[str, Callable[[float], object]]:
        return (f"write {entry.name}={value}",
                lambda now: twin.receive(sdo_write(twin, entry, value), now))

    def nmt(command: int) -> tuple[str, Callable[[float], object]]:
        return f"nmt {command:02X}h", lambda now: twin.receive(Frame(0, bytes((command, 0))), now)

    choices = [
        st.sampled_from(writable).flatmap(lambda e: st.builds(write, st.just(e), value_for(e))),
        st.sampled_from([0x01, 0x02, 0x80, 0x81, 0x82]).map(nmt),
        st.just(("host heartbeat",
                 lambda now: twin.receive(Frame(0x700 + HOST, b"\x05"), now))),
        st.just(("sync", lambda now: twin.receive(Frame(0x080, b""), now))),
    ]
    if timing:  # most often: start, stop or retime something
        choices += [st.sampled_from(timing).map(lambda e: write(e, 0)),
                    st.sampled_from(timing).flatmap(
                        lambda e: st.builds(write, st.just(e), value_for(e)))] * 2
    keys = description.face.keys
    if keys and hasattr(twin, "press"):
        choices.append(st.builds(
            lambda key, down: (f"key {key} {'down' if down else 'up'}",
                               lambda now: (twin.press if down else twin.release)(key, now)),
            st.integers(1, keys), st.booleans()))
    if description.face.encoders and hasattr(twin, "turn"):
        choices.append(st.builds(
            lambda knob, ticks: (f"turn {knob} {ticks}", lambda now: twin.turn(knob, ticks, now)),
            st.integers(1, len(description.face.encoders)), st.integers(-20, 20)))
    if "can_protocol" in description.table:
        choices.append(st.sampled_from(J1939_TIMING).flatmap(lambda name: j1939(twin, name)))
    return st.one_of(choices)


def j1939(twin: CanopenTwin, name: str) -> st.SearchStrategy[tuple[str, Callable[[float], object]]]:
    """A J1939 command to all, with values drawn from its fields' ranges."""
    command = COMMANDS_BY_NAME[name]
    fields = [st.sampled_from(sorted(field.accepted)) for field in command.fields]

    def build_frame(*values: int) -> tuple[str, Callable[[float], object]]:
        frame = Frame(compose_id(PGN_COMMAND, 0x80, GLOBAL_ADDRESS, PRIORITY),
                      command.encode(*values), extended=True)
        return f"j1939 {name}{values}", lambda now: twin.receive(frame, now)

    return st.tuples(*fields).map(lambda values: build_frame(*values))


#: steps between actions: whole tenths (the times of issue 17) and any time at all
STEPS = st.one_of(st.integers(0, 30).map(lambda k: k * 0.1),
                  st.floats(0, 3, allow_nan=False, allow_infinity=False))


@pytest.mark.parametrize(("model", "generation", "protocol"), VARIANTS, ids=IDS)
@settings(max_examples=60, deadline=None)
@given(data=st.data())
def test_every_deadline_is_consumed_when_time_reaches_it(
        model: Model, generation: str, protocol: str, data: st.DataObject) -> None:
    twin = build(model, generation, protocol)
    clock = Clock(twin)
    start = data.draw(STEPS, "power on")
    clock.run_to(start)
    twin.power_on(clock.now)
    for _ in range(data.draw(st.integers(1, 12), "actions")):
        clock.run_to(clock.now + data.draw(STEPS, "wait"))
        if data.draw(st.integers(0, 5), "power cycle?") == 0:
            off = data.draw(STEPS, "off time")
            twin.power_off()
            clock.run_to(clock.now + off)
            twin.power_on(clock.now)
            continue
        _, action = data.draw(operation(twin), "action")
        action(clock.now)
    clock.run_to(clock.now + 6.0)  # every show over, every timer run at least once more


@pytest.mark.parametrize(("model", "generation", "protocol"), VARIANTS, ids=IDS)
def test_a_power_cycle_at_any_tenth_of_a_second_ends_its_show(
        model: Model, generation: str, protocol: str) -> None:
    """Issue 17: a factory keypad power-cycled at t = 2.0 s was stuck at 4.56 s."""
    twin = build(model, generation, protocol)
    clock = Clock(twin)
    twin.power_on(0.0)
    for k in range(60):
        clock.run_to(k * 0.1)
        twin.power_off()
        clock.run_to(clock.now + 0.1)
        twin.power_on(clock.now)
    clock.run_to(clock.now + 5.0)


def test_periodic_deadlines_are_whole_ticks_from_their_origin() -> None:
    """No float sums: the 1000th period of 0.1 s from 2.1 s is 2.1 + 100 s, not a drifted sum,
    and a deadline below the clock's resolution still moves time."""
    timer = Ticker()
    timer.run(2.1, 100)
    for _ in range(1000):
        assert timer.due is not None
        assert timer.fire(timer.due)
    assert timer.due == 2.1 + 100100 / 1000
    huge = 2.0 ** 60
    assert at(huge, 1) > huge


@pytest.mark.parametrize("late_by", [1, 2, CATCH_UP_PERIODS - 2, CATCH_UP_PERIODS - 1,
                                     CATCH_UP_PERIODS, 3 * CATCH_UP_PERIODS])
def test_a_ticker_woken_late_owes_the_missed_periods_and_keeps_its_schedule(late_by: int) -> None:
    """Issue 22 item 5: a wake-up ``late_by`` periods after the due time owes the event of every
    missed period (up to CATCH_UP_PERIODS, sent late rather than dropped), and the schedule
    stays the device's clock: the next event is the next whole period from the origin, not a
    period from the late wake-up."""
    timer = Ticker()
    timer.run(1.0, 10)  # due at 1.01, 1.02, ...
    late = at(1.0, 10 + 10 * late_by + 3)  # 3 ticks into the period after late_by more
    assert timer.overdue(late) == min(late_by + 1, CATCH_UP_PERIODS)
    assert timer.fire(late) == min(late_by + 1, CATCH_UP_PERIODS)
    assert timer.due == at(1.0, 10 * (late_by + 2))
    assert timer.fire(timer.due) == 1
    assert timer.fire(timer.due - 0.001) == 0


def test_a_periodic_producer_woken_late_runs_once_per_period_owed() -> None:
    """The twins' timers (``twin.add_timer``) produce each owed period's frames, bounded."""
    runs: list[float] = []

    def produce(now: float) -> list[Frame]:
        runs.append(now)
        return []

    timer = Periodic(produce)
    timer.start(0.01, 0.0)
    timer.advance(0.025)  # 0.01 and 0.02 were due
    assert runs == [0.025, 0.025]
    assert timer.due == at(0.0, 30)
    timer.advance(10.0)  # a stall of ~1000 periods: only the last few are made up for
    assert len(runs) == 2 + CATCH_UP_PERIODS
    assert timer.due == at(0.0, 10010)


@settings(max_examples=300, deadline=None)
@given(origin=st.one_of(st.floats(0, 1e4), st.sampled_from([2.0 ** 40, 2.0 ** 52, 2.0 ** 60])),
       period=st.integers(1, 5000), retime=st.one_of(st.none(), st.integers(1, 5000)),
       wakes=st.lists(st.integers(0, 3 * CATCH_UP_PERIODS * 1000), min_size=1, max_size=8),
       jitter=st.sampled_from([0.0, -1e-12, 1e-12]))
def test_a_ticker_owes_what_counting_its_schedule_owes(
        origin: float, period: int, retime: int | None, wakes: list[int], jitter: float) -> None:
    """overdue() and fire() (with their fast path for the usual wake-up) owe exactly the ticks
    of the schedule, at(origin, count), at or before the wake-up, at most CATCH_UP_PERIODS,
    and leave the next one due strictly later: also where a tick is below the clock's
    resolution (huge origins) and at a hair before or after a due time."""
    timer = Ticker()
    timer.run(origin, period)
    start, count, step = origin, period, period
    if retime is not None:
        timer.retime(retime)  # counted from the due time
        start, count, step = at(origin, period), 0, retime
    for offset in sorted(wakes):
        assert timer.due == at(start, count)
        now = at(start, count) + offset * 1e-3 + jitter
        owed = 0
        while at(start, count + owed * step) <= now:
            owed += 1
        assert timer.overdue(now) == min(owed, CATCH_UP_PERIODS)
        assert timer.fire(now) == min(owed, CATCH_UP_PERIODS)
        count += owed * step
        assert owed == 0 or (timer.due is not None and timer.due > now)
