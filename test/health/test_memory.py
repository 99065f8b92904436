"""The run's memory of its residual per operating point (health/memory.py) and the monitor's
local detector on it: a change of the unit's torque far inside the twin's error band is seen
at a revisited operating point; a healthy unit off the twin by a steady 2 % is not a fault."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ballscrew_twin.health.memory import (
    MEMORY_AGE,
    MEMORY_BLOCKS,
    MIN_COUNT,
    SPEED_SLOPE,
    TEMPERATURE_SLOPE,
    TEMPERATURE_SPAN,
    ResidualMemory,
    bin_key,
)
from ballscrew_twin.health.monitor import HealthMonitor, feed
from ballscrew_twin.health.monitor_settings import MonitorSettings
from ballscrew_twin.health.residuals import UnitTwin
from ballscrew_twin.params import load_config

from .synthetic import bench_channels


def test_bins_split_direction_and_keep_close_points_together() -> None:
    here = bin_key(100.0, 293.15, 1500.0)
    assert here is not None
    assert bin_key(100.5, 293.3, 1502.0) == here
    assert bin_key(-100.0, 293.15, 1500.0) != here
    assert bin_key(130.0, 293.15, 1500.0) != here  # 0.11 decades away
    assert bin_key(100.0, 293.15, 1600.0) != here
    # a steady block and the same speed swept by 10 % within the block are apart, and so are
    # the two directions of the sweep
    rising = bin_key(100.0, 293.15, 1500.0, 10.0)
    assert rising not in (here, bin_key(100.0, 293.15, 1500.0, -10.0))
    assert bin_key(100.0, 293.15, 1500.0, 2.0) == here
    for speed, temperature, preload in ((0.0, 293.15, 1500.0), (math.nan, 293.15, 1500.0)):
        assert bin_key(speed, temperature, preload) is None
    assert bin_key(100.0, 293.15, 0.0) is None


def test_innovation_waits_for_the_bin_then_follows_its_formula() -> None:
    memory = ResidualMemory(floor=0.0)
    key = bin_key(50.0, 300.0, 1000.0)
    assert key is not None
    variance = 1e-6
    for _ in range(MIN_COUNT - 1):
        memory.update(key, 0.02, variance, 0.0, 300.0, 50.0)
        assert memory.innovation(key, 0.02, variance, 0.0, 300.0, 50.0) is None
    for _ in range(20):
        memory.update(key, 0.02, variance, 0.0, 300.0, 50.0)
    n = MIN_COUNT - 1 + 20
    # equal blocks: the bin's mean is the value, its variance v / n
    z = memory.innovation(key, 0.03, variance, 0.0, 300.0, 50.0)
    assert z == pytest.approx(0.01 / math.sqrt(variance + variance / n), rel=1e-12)
    # the floor adds in quadrature
    floored = ResidualMemory(floor=0.003)
    for _ in range(n):
        floored.update(key, 0.02, variance, 0.0, 300.0, 50.0)
    z = floored.innovation(key, 0.03, variance, 0.0, 300.0, 50.0)
    assert z == pytest.approx(0.01 / math.sqrt(variance + variance / n + 0.003**2), rel=1e-12)
    # the reference the classifier takes: the mean and the variance besides the block's own
    reference = floored.reference(key, 0.0, 300.0, 50.0)
    assert reference is not None
    assert reference[0] == pytest.approx(0.02, rel=1e-12)
    assert reference[1] == pytest.approx(variance / n + 0.003**2, rel=1e-12)
    assert floored.reference(key, MEMORY_AGE + 0.1, 300.0, 50.0) is None


def test_a_bin_starts_from_the_median_of_its_untested_blocks() -> None:
    """The first MIN_COUNT blocks of a bin are learnt untested; one the transient model
    underrated (the first block after a speed step, 7.6 % off) must not set the reference
    that every later healthy block is compared with (held-out unit 6000's false alarm)."""
    assert MIN_COUNT == 5  # the list below is one bin's first blocks
    first = [0.076, 0.0175, 0.006, -0.002, 0.0]  # relative residuals [-]
    variance = 1e-6
    memory = ResidualMemory(floor=0.0)
    key = bin_key(-2.86, 284.0, 820.0)
    assert key is not None
    for k, q in enumerate(first):
        memory.update(key, q, variance, 0.1 * k, 284.0, -2.86)
    n = len(first)
    z = memory.innovation(key, 0.006, variance, 0.6, 284.0, -2.86)
    assert z == pytest.approx(0.0, abs=1e-12)  # the median, 0.006, not the mean, 0.0195
    # later blocks move the mean as a running mean from there
    memory.update(key, 0.0, variance, 0.6, 284.0, -2.86)
    z = memory.innovation(key, 0.0, variance, 0.7, 284.0, -2.86)
    mean = 0.006 + (0.0 - 0.006) / (n + 1)
    assert z == pytest.approx(-mean / math.sqrt(variance + variance / (n + 1)), rel=1e-9)
    # with the default floor, healthy blocks at the unit's level after the outlier are quiet
    floored = ResidualMemory()
    for k, q in enumerate(first):
        floored.update(key, q, 1e-5, 0.1 * k, 284.0, -2.86)
    z = floored.innovation(key, 0.0, 1e-5, 0.6, 284.0, -2.86)
    assert z is not None and abs(z) < 2.0


def test_a_block_away_from_its_bins_speed_and_temperature_gets_the_slope_bounds() -> None:
    memory = ResidualMemory(floor=0.0)
    key = bin_key(40.0, 300.0, 1000.0)
    assert key is not None and bin_key(44.0, 301.0, 1000.0) == key
    for _ in range(30):
        memory.update(key, 0.0, 1e-6, 0.0, 300.0, 40.0)
    z = memory.innovation(key, 0.01, 1e-6, 1.0, 301.0, 44.0)
    apart = (SPEED_SLOPE * math.log(44.0 / 40.0)) ** 2 + TEMPERATURE_SLOPE**2
    assert z == pytest.approx(0.01 / math.sqrt(1e-6 + 1e-6 / 30 + apart), rel=1e-12)


def test_a_bin_forgets_beyond_its_memory_length() -> None:
    memory = ResidualMemory(floor=0.0)
    key = bin_key(50.0, 300.0, 1000.0)
    assert key is not None
    for _ in range(10 * MEMORY_BLOCKS):
        memory.update(key, 0.0, 1e-6, 0.0, 300.0, 50.0)
    memory.update(key, 1.0, 1e-6, 0.0, 300.0, 50.0)
    # an exponential memory of MEMORY_BLOCKS blocks: the new block weighs 1 / MEMORY_BLOCKS
    z = memory.innovation(key, 0.0, 0.0, 0.0, 300.0, 50.0)
    assert z == pytest.approx(-(1.0 / MEMORY_BLOCKS) / math.sqrt(1e-6 / MEMORY_BLOCKS), rel=1e-9)
    # a bin left alone for longer than MEMORY_AGE is no reference, and starts afresh
    assert memory.innovation(key, 0.0, 0.0, MEMORY_AGE + 0.1, 300.0, 50.0) is None
    memory.update(key, 0.5, 1e-6, MEMORY_AGE + 0.1, 300.0, 50.0)
    for k in range(MIN_COUNT - 1):
        memory.update(key, 0.5, 1e-6, MEMORY_AGE + 0.2 + 0.1 * k, 300.0, 50.0)
    z = memory.innovation(key, 0.5, 1e-6, MEMORY_AGE + 1.0, 300.0, 50.0)
    assert z == pytest.approx(0.0, abs=1e-12)
    # nor is a bin more than TEMPERATURE_SPAN away
    warmer = 300.0 + TEMPERATURE_SPAN + 0.1
    assert memory.innovation(key, 0.5, 1e-6, MEMORY_AGE + 1.0, warmer, 50.0) is None
    with pytest.raises(ValueError, match="floor"):
        ResidualMemory(floor=math.nan)


def _recording(change_at: float | None, change: float, duration: float = 120.0):
    """A unit 2 % above the twin (inside the nominal 3 % band) at 20 C / 1500 N, running a
    trapezoidal duty cycle of +-100 rad/s with reversals every 5 s; after ``change_at`` [s]
    its friction is ``change`` lower in magnitude. Torque meter 1 kHz, 0.2 mN m noise."""
    config = load_config(None)
    twin = UnitTwin(config)
    t = np.arange(0.0, duration, 1e-3)
    phase = np.mod(t, 10.0)
    w = 100.0 * np.clip(np.where(phase < 5.0, phase, 10.0 - phase) - 1.5, -1.0, 1.0)
    friction = 1.02 * twin.drag(w, 293.15, 1500.0)
    if change_at is not None:
        friction = np.where(t >= change_at, (1.0 - change) * friction, friction)
    rng = np.random.default_rng(7)
    torque = friction + config.screw.screw_inertia * np.gradient(w, t)
    torque = torque + rng.normal(0.0, 2e-4, len(t))
    channels = bench_channels(t, torque, w)
    return config, twin, channels


@pytest.mark.parametrize("detectors", [("cusum", "local", "spectral"), ("cusum", "spectral")])
def test_a_steady_offset_inside_the_band_is_no_fault(detectors: tuple[str, ...]) -> None:
    config, twin, channels = _recording(None, 0.0)
    monitor = HealthMonitor(config, MonitorSettings(detectors=detectors), twin=twin)
    feed(monitor, channels)
    assert monitor.alarm is None
    assert len(monitor.memory) >= 2  # both directions' plateaus were learnt


def test_a_small_change_is_seen_at_a_revisited_operating_point() -> None:
    config, twin, channels = _recording(60.0, 0.015)
    # the twin-only test does not see a 1.5 % change under its 3 % error band ...
    blind = HealthMonitor(config, MonitorSettings(detectors=("cusum", "spectral")), twin=twin)
    feed(blind, channels)
    assert blind.alarm is None
    # ... the run's memory of the same plateaus does, within the plateau it starts in
    monitor = HealthMonitor(config, MonitorSettings(), twin=twin)
    feed(monitor, channels)
    assert monitor.alarm is not None and monitor.alarm.detector == "local"
    assert 60.0 <= monitor.alarm.time < 62.0
    assert 59.0 <= monitor.alarm.onset <= monitor.alarm.time
