"""The fidelity step-down of ``fidelity: auto`` as a plain object: windows over the step
budget in a row, the reason it gives, and when it may not step down."""

from __future__ import annotations

import pytest

from ballscrew_twin.ros.step_down import OVER_BUDGET_WINDOWS, StepDown, may_step_down
from ballscrew_twin.ros.tick_counts import ON_TIME_NS

PERIOD = 1e-3  # s


def _fill(step_down: StepDown, step_time: float, ticks: int = 1000, late: int = 0) -> None:
    """``ticks`` ticks of ``step_time`` [s], the first ``late`` of them late."""
    for i in range(ticks):
        step_down.window.add(step_time, 2 * ON_TIME_NS if i < late else 0)


def _review(step_down: StepDown, active: bool = True) -> str | None:
    return step_down.review(active=active, model_name="m", step_budget=0.5, period=PERIOD)


@pytest.mark.parametrize(
    ("requested", "mode", "expected"),
    [
        ("auto", "realtime", True),
        ("auto", "catalog", False),  # nothing cheaper
        ("realtime", "realtime", False),  # an explicit choice is kept
        ("catalog", "catalog", False),
    ],
)
def test_only_auto_steps_down_and_not_below_the_catalogue(
    requested: str, mode: str, expected: bool
) -> None:
    assert may_step_down(requested, mode) is expected


def test_steps_down_after_windows_in_a_row_over_the_budget() -> None:
    step_down = StepDown()
    assert OVER_BUDGET_WINDOWS == 2
    _fill(step_down, 0.9e-3, late=100)
    assert _review(step_down) is None  # one window over: start-up or a hiccup
    assert step_down.over_budget == 1 and step_down.window.ticks == 0  # a new window
    _fill(step_down, 0.9e-3, late=100)
    why = _review(step_down)
    assert why == (
        "m took 0.900 ms per step on average (max 0.900 ms; budget 0.500 ms of the 1.000 ms "
        "step), 10.0% ticks late or skipped"
    )


def test_a_window_within_the_budget_starts_the_count_again() -> None:
    step_down = StepDown()
    for step_time in (0.9e-3, 0.1e-3, 0.9e-3):
        _fill(step_down, step_time)
        assert _review(step_down) is None
    assert step_down.over_budget == 1


def test_skipped_ticks_count_as_overdue() -> None:
    step_down = StepDown(windows=1)
    _fill(step_down, 0.9e-3, ticks=900)
    step_down.window.skipped += 100
    why = _review(step_down)
    assert why is not None and "10.0% ticks late or skipped" in why


def test_inactive_drops_the_window_and_counts_nothing() -> None:
    step_down = StepDown()
    _fill(step_down, 0.9e-3)
    assert _review(step_down) is None and step_down.over_budget == 1
    _fill(step_down, 0.9e-3)
    assert _review(step_down, active=False) is None
    assert step_down.window.ticks == 0 and step_down.over_budget == 1


def test_restart_forgets_the_windows_over_the_budget() -> None:
    step_down = StepDown()
    _fill(step_down, 0.9e-3)
    _review(step_down)
    _fill(step_down, 0.9e-3, ticks=10)
    step_down.restart()
    assert step_down.over_budget == 0 and step_down.window.ticks == 0


def test_window_full_after_one_simulated_second() -> None:
    step_down = StepDown()
    _fill(step_down, 1e-5, ticks=99)
    assert not step_down.window_full(100.0)
    _fill(step_down, 1e-5, ticks=1)
    assert step_down.window_full(100.0)
    assert step_down.window_full(0.5)  # below 1 Hz: every tick
