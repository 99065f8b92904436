"""The health node's /clock watchdog and diagnostic checks, without ROS."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ballscrew_twin.health.monitor import HealthMonitor, feed
from ballscrew_twin.health.monitor_settings import MonitorSettings
from ballscrew_twin.health.residuals import UnitTwin
from ballscrew_twin.health.tracker import TrackerSettings
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


@pytest.mark.parametrize("offset_drift", [0.0, 0.02])
def test_health_check_shows_the_drift_tracked(offset_drift: float) -> None:
    config = load_config(None)
    twin = UnitTwin(config)
    t = np.arange(0.0, 12.0, 1e-3)
    w = np.full(len(t), 30.0)
    torque = twin.drag(w, 293.15, 1500.0) + np.random.default_rng(2).normal(0, 2e-4, len(t))
    slow = t[::100]  # s, 10 Hz speed, temperature [K] and preload [N]
    channels = {
        "torque": (t, torque),
        "speed": (slow, w[::100]),
        "temperature": (slow, np.full(len(slow), 293.15)),
        "preload": (slow, np.full(len(slow), 1500.0)),
    }
    settings = MonitorSettings(tracker=TrackerSettings(temperature_drift=offset_drift))
    expected = ["tracked bias [N m]", "tracked friction scale [-]", "tracked preload change [N]"]
    if offset_drift > 0.0:
        expected.append("tracked temperature offset [K]")
    # a block compared before the filter's first step (the sensor noise not learnt yet):
    # every tracked state listed, the offset (no prior) at 0 +- 0
    first = HealthMonitor(config, settings, twin=twin)
    first.compared_time = 0.1
    values = dict(health_check(first, None, ()).values)
    assert [k for k in values if k.startswith("tracked ")] == expected
    if offset_drift > 0.0:
        assert values["tracked temperature offset [K]"] == "0 +- 0"
    monitor = HealthMonitor(config, settings, twin=twin)
    feed(monitor, channels)
    values = dict(health_check(monitor, monitor.samples[-1], ()).values)
    tracked = [k for k in values if k.startswith("tracked ")]
    assert tracked == expected
    value, std = values["tracked friction scale [-]"].split(" +- ")
    assert float(std) > 0.0 and abs(float(value)) < 3.0 * float(std)
