"""The health node's /clock watchdog and diagnostic checks, without ROS."""

from __future__ import annotations

import math

import pytest

from ballscrew_twin.health.monitor import HealthMonitor
from ballscrew_twin.params import load_config
from ballscrew_twin.ros import diagnostics
from ballscrew_twin.ros.health_diagnostics import (
    ClockWatch,
    clock_check,
    health_check,
    stale_health,
    torque_check,
)


def test_clock_watch_goes_stale_once_and_resumes() -> None:
    watch = ClockWatch(clock_ns=5 * 10**9, moved=100.0)
    assert watch.observe(5 * 10**9, 101.0, sim_time=True, timeout=2.0) is None
    assert watch.observe(5 * 10**9, 102.5, sim_time=True, timeout=2.0) == "stale"
    assert watch.stale and watch.text(103.0) == "/clock stopped at 5.000 s, 3.0 s ago"
    assert watch.observe(5 * 10**9, 104.0, sim_time=True, timeout=2.0) is None  # said once
    assert watch.observe(6 * 10**9, 105.0, sim_time=True, timeout=2.0) == "resumed"
    assert not watch.stale and watch.moved == 105.0


def test_clock_watch_on_wall_time_never_goes_stale() -> None:
    watch = ClockWatch(clock_ns=0, moved=0.0)
    assert watch.text(1.5) == "no /clock received for 1.5 s"
    assert watch.observe(0, 100.0, sim_time=False, timeout=2.0) is None
    assert not watch.stale


def test_clock_and_stale_health_checks() -> None:
    watch = ClockWatch(clock_ns=2 * 10**9, moved=0.0)
    health = diagnostics.Check("health", diagnostics.OK, "OK", (("blocks", "3"),))
    assert stale_health(health, watch, 1.0) is health
    assert clock_check(watch, 1.0).message == "/clock at 2.000 s"
    watch.observe(2 * 10**9, 5.0, sim_time=True, timeout=2.0)
    stale = stale_health(health, watch, 5.0)
    assert stale.level == diagnostics.STALE and stale.values == health.values
    assert stale.message == "STALE: /clock stopped at 2.000 s, 5.0 s ago; last: OK"
    assert clock_check(watch, 5.0).level == diagnostics.STALE


@pytest.mark.parametrize(
    ("age", "level", "message"),
    [
        (math.inf, diagnostics.STALE, "no torque received"),
        (3.0, diagnostics.STALE, "last sample 3.00 s ago"),
        (0.5, diagnostics.OK, "last sample 0.50 s ago"),
    ],
)
def test_torque_check(age: float, level: int, message: str) -> None:
    check = torque_check(age, stale_after=2.0)
    assert (check.level, check.message) == (level, message)


def test_health_check_before_the_first_comparison() -> None:
    monitor = HealthMonitor(load_config(None))
    check = health_check(monitor, None, (("dropped samples", "0"),))
    assert check.level == diagnostics.STALE
    assert check.message == "no comparison yet: waiting for speed, temperature, preload"
    assert [k for k, _ in check.values] == ["blocks", "dropped samples", "gated [s]"]
