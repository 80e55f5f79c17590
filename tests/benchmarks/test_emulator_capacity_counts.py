"""The emulator capacity benchmark's missed-frame count: what it charges and what it does not
(the figures decide whether issue 22's "no missed frame" target holds)."""

from benchmarks.emulator_capacity import PERIOD, _schedule_figures


def test_a_frame_due_in_the_windows_last_period_is_not_charged_as_missed() -> None:
    sends = {0x701: [k * PERIOD for k in range(99)]}  # slots 0-98 on time
    end = 99 * PERIOD + PERIOD / 20  # slot 99 is due just before the end; its frame in flight
    assert _schedule_figures(sends, end)[2] == 0


def test_a_sender_whose_period_stretches_misses_the_slots_it_never_filled() -> None:
    sends = {0x701: [k * 1.25 * PERIOD for k in range(80)]}  # 80 frames in 100 periods
    _, sent, missed = _schedule_figures(sends, 100 * PERIOD)
    assert (sent, missed) == (80, 20)  # slots 0-99 are due a whole period before the end


def test_a_late_frame_that_catches_up_is_late_not_missed() -> None:
    times = [k * PERIOD for k in range(100)]
    times[50] += 1.5 * PERIOD  # 15 ms late, the next on time
    times[50:52] = sorted(times[50:52])
    lateness, _, missed = _schedule_figures({0x701: times}, 100 * PERIOD)
    assert missed == 0
    assert max(lateness) > PERIOD
