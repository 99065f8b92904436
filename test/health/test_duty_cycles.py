"""EMA duty cycles: the patterns the issue names, within their ranges, reproducible."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ballscrew_twin.errors import ConfigError
from ballscrew_twin.health.duty_cycles import (
    CELSIUS_ZERO,
    COMMISSIONING_WARMUP,
    PEAK_SPEED_RPM,
    RPM,
    SINE_FREQUENCY,
    draw_trajectory,
    segment_speed,
)


def _reversals(speed: np.ndarray) -> int:
    signs = np.sign(speed[np.abs(speed) > 1e-9])
    return int(np.count_nonzero(np.diff(signs) != 0))


def test_a_sine_segment_reverses_twice_per_cycle() -> None:
    rng = np.random.default_rng(0)
    t = np.arange(0.0, 30.0, 1e-3)
    speed = segment_speed("sine", t, rng, 3000.0)
    # the frequency it drew, from the same generator state
    again = np.random.default_rng(0)
    frequency = math.exp(again.uniform(*np.log(SINE_FREQUENCY)))
    assert abs(_reversals(speed) - 2.0 * frequency * 30.0) <= 2
    # position = integral of the speed stays bounded (a position command, not a drift)
    position = np.cumsum(speed) * 1e-3
    assert np.ptp(position) <= 2.0 * np.max(np.abs(speed)) / (2 * math.pi * frequency) * 1.01


@pytest.mark.parametrize("seed", range(8))
def test_trajectories_stay_within_their_ranges(seed: int) -> None:
    trajectory = draw_trajectory(seed, 300.0)
    assert np.max(np.abs(trajectory.speed)) <= PEAK_SPEED_RPM[1] * RPM * 1.0001
    assert 600.0 <= trajectory.preload[0] <= 2500.0 and np.ptp(trajectory.preload) == 0.0
    celsius = trajectory.temperature - CELSIUS_ZERO
    assert celsius.min() >= -20.0 and celsius.max() <= 45.0
    # every segment starts and ends at standstill and the joins are ramped: bounded dw/dt
    assert trajectory.speed[0] == 0.0
    acceleration = np.abs(np.diff(trajectory.speed)) / 1e-3
    assert np.max(acceleration) <= 2.0 * PEAK_SPEED_RPM[1] * RPM / 0.02 * 1.01  # +-peak in 20 ms
    assert draw_trajectory(seed, 300.0).speed.tobytes() == trajectory.speed.tobytes()


def test_a_cold_start_warms_from_below_5_c() -> None:
    trajectory = draw_trajectory(3, 1200.0, cold_start=True)
    celsius = trajectory.temperature - CELSIUS_ZERO
    assert celsius[0] <= 5.0 and celsius[-1] > celsius[0] + 10.0
    assert np.all(np.diff(celsius) >= 0.0)
    assert "cold start" in trajectory.segments[0][1]


def test_every_kind_is_drawn_and_reversals_and_stops_happen() -> None:
    kinds = set()
    reversals = 0
    stopped = 0.0
    for seed in range(6):
        trajectory = draw_trajectory(seed, 600.0)
        kinds |= {kind for _, kind in trajectory.segments[1:]}
        reversals += _reversals(trajectory.speed)
        stopped += float(np.mean(np.abs(trajectory.speed) < 0.1))
    assert kinds == {"sine", "trapezoid", "steps", "reversal"}
    assert reversals > 100 and stopped > 0.0


def test_a_bad_request_is_refused() -> None:
    with pytest.raises(ConfigError):
        draw_trajectory(0, -1.0)
    with pytest.raises(ConfigError, match="kinds"):
        draw_trajectory(0, 10.0, kinds=("zigzag",))


def test_a_commissioning_warm_up_spans_the_working_temperatures() -> None:
    for seed in range(5):
        trajectory = draw_trajectory(seed, 600.0, cold_start=True, warmup=COMMISSIONING_WARMUP)
        celsius = trajectory.temperature - 273.15
        assert -20.0 <= celsius[0] <= -10.0
        # within 600 s it passes 30 C (ambient runs: 10-35 C; cold starts end at 30-45 C)
        assert celsius[-1] >= 30.0
        assert np.all(np.diff(celsius) >= 0.0)
