"""Kalman tracker of bias, friction scale and preload change: truth recovery and innovations
(the temperature offset: test_temperature_offset.py)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import chi2

from ballscrew_twin.errors import ConfigError
from ballscrew_twin.health.tracker import DriftTracker, TrackerSettings

NOISE = 5e-5  # N m, standard deviation of one block mean
DT = 0.1  # s


def _ops(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Predicted torque and preload sensitivity of a twin whose operating point moves:
    torque proportional to a speed factor, sensitivity to the preload only (ratio changes)."""
    k = np.arange(n)
    torque = 0.012 + 0.008 * (np.sin(2 * np.pi * k / 150) > 0)  # N m, two speeds
    sensitivity = 1.2e-5 + 0.4e-5 * (np.sin(2 * np.pi * k / 70) > 0)  # N m / N, two preloads
    return torque, sensitivity


def test_moving_operating_point_separates_bias_scale_and_preload() -> None:
    truth = np.array([3e-4, 0.04, -30.0, 0.0])  # N m, -, N, K (the offset not tracked)
    n = 1500
    torque, sensitivity = _ops(n)
    rng = np.random.default_rng(7)
    tracker = DriftTracker(TrackerSettings(temperature_drift=0.0))
    for i in range(n):
        z = truth[0] + (1 + truth[1]) * torque[i] + truth[2] * sensitivity[i]
        tracker.step(z + rng.normal(0, NOISE), torque[i], sensitivity[i], NOISE**2, DT)
    error = np.abs(tracker.state - truth)[:3]
    assert np.all(error < 4 * tracker.std[:3]), (tracker.state, tracker.std)
    # and each is resolved far better than its prior; the untracked offset stays 0
    assert np.all(tracker.std[:3] < 0.2 * np.array([2e-3, 0.05, 20.0]))
    assert tracker.state[3] == 0.0 and tracker.std[3] == 0.0


def test_innovations_are_standard_normal_under_slow_drift() -> None:
    settings = TrackerSettings()
    n = 3000
    torque, sensitivity = _ops(n)
    rng = np.random.default_rng(8)
    tracker = DriftTracker(settings)
    bias = 0.0
    e = np.empty(n)
    for i in range(n):
        bias += rng.normal(0, settings.bias_drift * np.sqrt(DT))  # drift the filter expects
        z = bias + torque[i] + rng.normal(0, NOISE)
        e[i] = tracker.step(z, torque[i], sensitivity[i], NOISE**2, DT).normalized
    tail = e[200:]
    low, high = chi2.interval(0.999, len(tail))
    assert low <= np.sum(tail**2) <= high
    assert abs(np.mean(tail)) < 4 / np.sqrt(len(tail))


def test_sudden_step_shows_in_the_innovations_and_freezing_keeps_the_state() -> None:
    torque, sensitivity = _ops(400)
    rng = np.random.default_rng(9)
    tracker = DriftTracker(TrackerSettings())
    for i in range(300):
        tracker.step(torque[i] + rng.normal(0, NOISE), torque[i], sensitivity[i], NOISE**2, DT)
    tracker.frozen = True
    before = tracker.state
    jump = tracker.step(torque[300] + 2e-3, torque[300], sensitivity[300], NOISE**2, DT)
    assert jump.normalized > 10.0
    np.testing.assert_array_equal(tracker.state, before)


def test_bad_settings_and_steps_are_named() -> None:
    with pytest.raises(ConfigError, match="scale_drift"):
        TrackerSettings(scale_drift=-1.0)
    tracker = DriftTracker(TrackerSettings())
    with pytest.raises(ValueError, match="dt"):
        tracker.step(0.0, 0.01, 1e-5, NOISE**2, 0.0)
    with pytest.raises(ValueError, match="R ="):
        tracker.step(0.0, 0.01, 1e-5, float("nan"), DT)


def test_an_error_shared_by_many_blocks_teaches_the_state_what_one_block_would() -> None:
    # 70 blocks at one operating point, all 2 sigma off (the twin's own error there, not a
    # drift), with a commissioned unit's tight priors: updated as independent measurements the
    # friction scale absorbs it; updated as one shared error (R x 100) it moves no further
    # than one block's evidence allows.
    settings = TrackerSettings(bias_prior=2e-5, scale_prior=2.5e-3, preload_prior=1.0)
    torque, sensitivity = 0.014, 1.8e-5
    model = 0.08 * torque  # N m, the twin's error there
    offset = 2.0 * model
    moved = []
    for shared in (1.0, 100.0):
        tracker = DriftTracker(settings)
        for _ in range(70):
            tracker.step(
                torque + offset,
                torque,
                sensitivity,
                NOISE**2 + model**2,
                DT,
                update_variance=NOISE**2 + shared * model**2,
            )
        moved.append(tracker.state[1])
    white, correlated = moved
    one_block = DriftTracker(settings)
    one_block.step(torque + offset, torque, sensitivity, NOISE**2 + model**2, DT)
    assert white > 20 * correlated > 0.0
    assert correlated < 2.0 * one_block.state[1]
    with pytest.raises(ValueError, match="update R"):
        DriftTracker(TrackerSettings()).step(
            0.0, 0.01, 1e-5, NOISE**2, DT, update_variance=0.5 * NOISE**2
        )
