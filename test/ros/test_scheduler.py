"""Fixed-step tick schedule: catches up, skips and restarts, never drifts (pure Python)."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from ballscrew_twin.errors import ConfigError
from ballscrew_twin.ros.scheduler import FORWARD_JUMP_NS, TickScheduler

PERIOD = 1_000_000  # ns (1 kHz)


def _started(max_catch_up: int = 5, origin: int = 10 * PERIOD) -> TickScheduler:
    s = TickScheduler(PERIOD, max_catch_up)
    s.start(origin)
    return s


def test_one_tick_per_period_stamped_on_the_grid() -> None:
    s = _started()
    for k in range(1, 50):
        plan = s.due(s.origin_ns + k * PERIOD + 300_000)  # woken 0.3 ms late
        assert list(plan.ticks) == [k]
        assert s.time_of(k) == 10 * PERIOD + k * PERIOD
        assert plan.skipped == 0


def test_early_wake_runs_nothing() -> None:
    s = _started()
    assert not s.due(s.origin_ns + PERIOD - 1).ticks


def test_short_stall_is_caught_up_in_order() -> None:
    s = _started(max_catch_up=5)
    s.due(s.origin_ns + PERIOD)
    plan = s.due(s.origin_ns + 5 * PERIOD)
    assert list(plan.ticks) == [2, 3, 4, 5]
    assert plan.skipped == 0


def test_long_stall_runs_the_newest_tick_and_counts_the_rest() -> None:
    s = _started(max_catch_up=5)
    plan = s.due(s.origin_ns + 40 * PERIOD)
    assert list(plan.ticks) == [40]
    assert plan.skipped == 39


def test_clock_jump_backwards_restarts_at_the_new_time() -> None:
    s = _started()
    s.due(s.origin_ns + 3 * PERIOD)
    back = 2 * PERIOD
    plan = s.due(back)
    assert plan.jumped_back
    assert list(plan.ticks) == [0]
    assert s.time_of(0) == back
    assert list(s.due(back + PERIOD).ticks) == [1]


def test_far_forward_jump_restarts_instead_of_skipping() -> None:
    s = _started()
    later = s.origin_ns + FORWARD_JUMP_NS + 5 * PERIOD
    plan = s.due(later)
    assert plan.jumped_forward and plan.skipped == 0
    assert s.time_of(0) == later


def test_forward_jump_of_a_wall_clock_counts_the_ticks_passed_as_skipped() -> None:
    """On wall time the leap is a stall: the restart runs one tick, the rest were missed."""
    s = TickScheduler(PERIOD, 3, wall_clock=True)
    s.start(1_000 * PERIOD)
    s.due(s.origin_ns + 2 * PERIOD)  # ticks 1, 2 run: the last one handed out is due here
    last_due = s.time_of(2)
    later = last_due + FORWARD_JUMP_NS + 5 * PERIOD + PERIOD // 2
    plan = s.due(later)
    passed = (later - last_due) // PERIOD  # grid points due since the last tick handed out
    assert plan.jumped_forward and list(plan.ticks) == [0]
    assert plan.skipped == passed - 1
    assert s.time_of(0) == later


def test_first_call_without_start_begins_there() -> None:
    s = TickScheduler(PERIOD, 3)
    assert list(s.due(123).ticks) == [0]
    assert s.time_of(0) == 123


@pytest.mark.parametrize(
    ("period", "catch_up", "message"),
    [
        (0, 1, "period_ns = 0 is outside the allowed range (0, inf] ns"),
        (-5, 1, "period_ns = -5 is outside the allowed range (0, inf] ns (must not be negative)"),
        (1.5, 1, "period_ns: expected a whole number, got 1.5"),
        (PERIOD, 0, "max_catch_up = 0 is outside the allowed range [1, inf] -"),
    ],
)
def test_bad_arguments(period: int, catch_up: int, message: str) -> None:
    with pytest.raises(ConfigError) as err:
        TickScheduler(period, catch_up)
    assert str(err.value).startswith(message), str(err.value)


@given(
    st.lists(st.integers(min_value=0, max_value=30 * PERIOD), min_size=1, max_size=60),
    st.integers(min_value=1, max_value=20),
)
def test_no_drift(steps: list[int], max_catch_up: int) -> None:
    """Over any monotonic clock: ticks run + ticks skipped = periods elapsed, every tick handed
    out is due, and the ticks are consecutive or separated by the skipped ones."""
    s = _started(max_catch_up)
    now = s.origin_ns
    run = skipped = 0
    last = 0
    for step in steps:
        now += step
        plan = s.due(now)
        if plan.ticks:
            assert plan.ticks[0] == last + 1 + plan.skipped
            assert s.time_of(plan.ticks[-1]) <= now
            last = plan.ticks[-1]
        run += len(plan.ticks)
        skipped += plan.skipped
        assert len(plan.ticks) <= max_catch_up
    assert run + skipped == (now - s.origin_ns) // PERIOD
