"""The twin node's ``real time`` diagnostic: its on-time threshold is a parameter, and the ticks
skipped while the node starts (model loading, first steps) are counted apart, not a warning."""

from __future__ import annotations

from rclpy.executors import SingleThreadedExecutor
from rclpy.parameter import Parameter

from ballscrew_twin.ros import diagnostics
from ballscrew_twin.ros.inputs import NS_PER_S
from ballscrew_twin.ros.tick_counts import ON_TIME_NS, TickWindow
from ballscrew_twin.ros.twin_node import STARTUP_GRACE_NS, TwinNode
from ballscrew_twin.ros.twin_parameters import MIN_ON_TIME_SHARE

from .conftest import SpinUntil
from .test_twin_node import _twin


def _window(ticks: int, late: int) -> TickWindow:
    """``ticks`` published ticks of which the first ``late`` were late."""
    w = TickWindow()
    for i in range(ticks):
        w.add(1e-5, 2 * ON_TIME_NS if i < late else 0)
    return w


def _level(twin: TwinNode, w: TickWindow) -> int:
    return twin.real_time_check(w, 1.0).level


def test_on_time_threshold_is_a_run_time_parameter(executor: SingleThreadedExecutor) -> None:
    twin = _twin(executor, fidelity="catalog", tick_source="executor")
    assert twin.get_parameter("min_on_time_share").value == MIN_ON_TIME_SHARE == 0.98
    three_late = _window(100, 3)  # 97 % on time
    assert _level(twin, three_late) == diagnostics.WARN
    assert _level(twin, _window(100, 1)) == diagnostics.OK  # 99 %: 99.9 % hard-coded warned
    assert twin.set_parameters([Parameter("min_on_time_share", value=0.95)])[0].successful
    assert _level(twin, three_late) == diagnostics.OK
    refused = twin.set_parameters([Parameter("min_on_time_share", value=1.5)])[0]
    assert not refused.successful


def test_ticks_skipped_at_start_up_are_not_a_warning(
    executor: SingleThreadedExecutor, spin_until: SpinUntil
) -> None:
    # Ticks driven by the executor's timer: none runs until the executor spins.
    twin = _twin(executor, fidelity="catalog", tick_source="executor", sim_rate_hz=100.0)
    assert twin.ticks.starting_up
    with twin.tick_lock:
        twin.book_skipped(40)  # e.g. the first step loading the model
        w = twin.ticks.window
    for _ in range(10):
        w.add(1e-5, 0)
    check = twin.real_time_check(w, 1.0)
    assert check.level == diagnostics.OK, check.message
    values = dict(check.values)
    assert values["skipped ticks at start-up"] == "40"
    assert values["skipped ticks (window / total)"] == "0 / 0"

    # Start-up ends with the first tick on time (at the latest after the grace time).
    assert spin_until(
        executor, lambda: not twin.ticks.starting_up, timeout=STARTUP_GRACE_NS / NS_PER_S + 5.0
    )
    with twin.tick_lock:
        twin.book_skipped(5)
        w = twin.ticks.window
    check = twin.real_time_check(w, 1.0)
    assert check.level == diagnostics.WARN
    assert "5 skipped" in check.message
    assert twin.ticks.totals.startup_skipped == 40
