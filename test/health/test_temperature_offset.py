"""The tracker's temperature offset: a thermometer that drifts from the unit's temperature is
learnt where the lubricant carries the drag, and told apart from a friction scale."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from ballscrew_twin.errors import ConfigError
from ballscrew_twin.health.monitor import HealthMonitor, feed
from ballscrew_twin.health.monitor_settings import MonitorSettings
from ballscrew_twin.health.residuals import UnitTwin
from ballscrew_twin.health.tracker import DriftTracker, TrackerSettings
from ballscrew_twin.params import load_config

from .synthetic import PRELOAD, TEMPERATURE, bench_channels

NOISE = 5e-5  # N m, standard deviation of one block mean
DT = 0.1  # s
#: Priors of the tracked states: bias [N m], scale [-], preload change [N], offset [K].
PRIORS = np.array([2e-3, 0.05, 20.0, 2.0])


def _cycle(n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Torque [N m], dT/dF [N m / N] and dT/dTh [N m / K] of a twin moving between three
    speeds, from slow (dry and hysteresis friction: 12 mN m, hardly any temperature
    sensitivity) to fast (lubricant shear: 20 mN m, -2 % per kelvin), at two preloads. Bias,
    scale and offset need three speeds: at two, one of their combinations is not observed."""
    k = np.arange(n)
    level = (k // 75) % 3
    torque = np.array([0.012, 0.015, 0.020])[level]
    preload = 1.2e-5 + 0.4e-5 * (np.sin(2 * np.pi * k / 70) > 0)
    temperature = np.array([-2e-5, -1.8e-4, -4e-4])[level]
    return torque, preload, temperature


def _settings(prior: float, drift: float) -> TrackerSettings:
    return TrackerSettings(
        bias_prior=PRIORS[0],
        scale_prior=PRIORS[1],
        preload_prior=PRIORS[2],
        temperature_prior=prior,
        temperature_drift=drift,
    )


def test_without_drift_the_filter_is_the_batch_least_squares_fit() -> None:
    # With (almost) no random walk the Kalman posterior is the regularised weighted least
    # squares estimate (P0^-1 + H'H / R)^-1 H'z / R, solved here directly in one batch
    settings = replace(
        _settings(PRIORS[3], 1e-12), bias_drift=1e-12, scale_drift=1e-12, preload_drift=1e-12
    )
    torque, preload, temperature = _cycle(600)
    h = np.column_stack([np.ones_like(torque), torque, preload, temperature])
    truth = np.array([2e-4, 0.03, -15.0, -1.5])
    rng = np.random.default_rng(11)
    z = h @ truth + rng.normal(0.0, NOISE, len(torque))
    tracker = DriftTracker(settings)
    for i in range(len(torque)):
        tracker.step(
            torque[i] + z[i], torque[i], preload[i], NOISE**2, DT,
            temperature_sensitivity=temperature[i],
        )  # fmt: skip
    information = np.diag(PRIORS**-2.0) + h.T @ h / NOISE**2
    batch = np.linalg.solve(information, h.T @ z / NOISE**2)
    np.testing.assert_allclose(tracker.state, batch, rtol=1e-6, atol=1e-12)
    np.testing.assert_allclose(tracker.std, np.sqrt(np.diag(np.linalg.inv(information))), 1e-6)


def test_a_temperature_offset_is_told_apart_from_a_friction_scale() -> None:
    truth = np.array([3e-4, 0.04, -30.0, -1.2])
    torque, preload, temperature = _cycle(3000)
    rng = np.random.default_rng(12)
    tracker = DriftTracker(_settings(PRIORS[3], 0.01))
    for i in range(len(torque)):
        h = np.array([1.0, torque[i], preload[i], temperature[i]])
        z = torque[i] + h @ truth + rng.normal(0.0, NOISE)
        tracker.step(z, torque[i], preload[i], NOISE**2, DT, temperature_sensitivity=temperature[i])
    error = np.abs(tracker.state - truth)
    assert np.all(error < 4 * tracker.std), (tracker.state, tracker.std)
    assert tracker.std[3] < 0.2 * PRIORS[3]
    assert tracker.expected(0.02, 1e-5, tracker.state, -4e-4) == pytest.approx(
        0.02 + tracker.observation(0.02, 1e-5, -4e-4) @ tracker.state
    )


def test_a_negative_temperature_setting_is_named() -> None:
    with pytest.raises(ConfigError, match="temperature_drift"):
        TrackerSettings(temperature_drift=-0.01)
    # tracked by default, from the commissioned shift (no prior uncertainty)
    assert TrackerSettings().temperature_prior == 0.0
    assert TrackerSettings().temperature_drift == 0.02
    assert TrackerSettings().tracks_temperature
    assert not TrackerSettings(temperature_drift=0.0).tracks_temperature


#: Thermometer drift of the monitor test [K/s]: 2 K in 200 s.
DRIFT = 0.01


def _drifting_thermometer() -> tuple[object, UnitTwin, dict]:
    """A unit equal to the twin at TEMPERATURE, stepping through 3, 20 and 60 rad/s every 4 s
    for 200 s; its thermometer reads TEMPERATURE + DRIFT t. 1 kHz torque with 0.2 mN m noise."""
    config = load_config(None)
    twin = UnitTwin(config)
    t = np.arange(0.0, 200.0, 1e-3)
    w = np.array([3.0, 20.0, 60.0])[(np.floor(t / 4.0) % 3).astype(int)]
    torque = twin.drag(w, TEMPERATURE, PRELOAD)
    torque += np.random.default_rng(13).normal(0.0, 2e-4, len(t))
    channels = bench_channels(t, torque, w)
    stamps, _ = channels["temperature"]
    channels["temperature"] = (stamps, TEMPERATURE + DRIFT * stamps)
    return config, twin, channels


def test_the_monitor_learns_a_drifting_thermometer() -> None:
    config, twin, channels = _drifting_thermometer()
    late_bias = {}
    for drift in (0.0, 0.3):
        settings = MonitorSettings(tracker=TrackerSettings(temperature_drift=drift))
        monitor = HealthMonitor(config, settings, twin=twin)
        samples = feed(monitor, channels)
        late = [
            s.innovation
            for s in samples
            if s.time > 150.0 and s.operating_point is not None and np.isfinite(s.innovation)
        ]
        late_bias[drift] = float(np.mean(late))
        if drift > 0.0:  # the unit is DRIFT t colder than the reading: 1.5-2 K at the end
            assert -2.3 < monitor.tracker.state[3] < -1.3, monitor.tracker.state
        else:
            assert monitor.tracker.state[3] == 0.0
    assert abs(late_bias[0.3]) < 0.5 * abs(late_bias[0.0]), late_bias
