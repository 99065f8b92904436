"""Sensor models: sampling, quantisation, noise statistics, speed ripple, angle; validation."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ballscrew_twin.errors import ConfigError
from ballscrew_twin.health.sensors import (
    Encoder,
    SensorSet,
    TorqueMeter,
    cumulative_angle,
    measure,
    quantise,
    sample_times,
    sensors_from_mapping,
    speed_with_ripple,
)


def test_sample_times_are_k_over_rate_within_the_duration() -> None:
    t = sample_times(200.0, 2.0)
    assert len(t) == 400
    assert t[0] == 0.0
    np.testing.assert_allclose(np.diff(t), 1.0 / 200.0, rtol=1e-12)
    assert t[-1] < 2.0
    assert len(sample_times(3.0, 1.0)) == 3  # 0, 1/3, 2/3


def test_quantise_rounds_to_multiples_and_zero_resolution_is_identity() -> None:
    x = np.array([0.012349, -0.00049, 0.00051])
    np.testing.assert_allclose(quantise(x, 1e-3), [0.012, -0.0, 0.001], atol=1e-15)
    np.testing.assert_array_equal(quantise(x, 0.0), x)
    q = quantise(np.linspace(-1, 1, 1001), 0.03)
    np.testing.assert_allclose(np.round(q / 0.03) * 0.03, q, atol=1e-12)


def test_measure_has_the_bias_and_noise_asked_for() -> None:
    rng = np.random.default_rng(0)
    n = 40_000
    true = np.full(n, 0.02)
    noise, bias, res = 2e-4, 3e-4, 1e-5
    y = measure(true, noise, bias, res, rng)
    # mean within 5 standard errors, std within 5 standard errors of the sample std
    assert abs(y.mean() - (0.02 + bias)) < 5 * noise / math.sqrt(n)
    expected_std = math.sqrt(noise**2 + res**2 / 12.0)  # quantisation adds res^2 / 12
    assert abs(y.std() - expected_std) < 5 * expected_std / math.sqrt(2 * n)


def test_same_seed_same_readings_other_seed_other_readings() -> None:
    a = measure(np.zeros(10), 1.0, 0.0, 0.0, np.random.default_rng(7))
    b = measure(np.zeros(10), 1.0, 0.0, 0.0, np.random.default_rng(7))
    c = measure(np.zeros(10), 1.0, 0.0, 0.0, np.random.default_rng(8))
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, c)


def test_cumulative_angle_is_exact_for_constant_and_linear_speed() -> None:
    t = np.linspace(0.0, 2.0, 201)
    np.testing.assert_allclose(cumulative_angle(t, np.full_like(t, 3.0)), 3.0 * t, atol=1e-12)
    # w = a t -> angle = a t^2 / 2 (trapezoids are exact for a linear integrand)
    np.testing.assert_allclose(cumulative_angle(t, 5.0 * t), 2.5 * t**2, atol=1e-12)


def test_speed_ripple_has_its_amplitude_and_order_per_revolution() -> None:
    angle = np.linspace(1e-3, 2.0 * math.pi - 1e-3, 1999)
    w = speed_with_ripple(np.full_like(angle, 10.0), angle, 0.02, 3.0)
    assert w.max() == pytest.approx(10.2, rel=1e-6)
    assert w.min() == pytest.approx(9.8, rel=1e-6)
    # three periods per revolution: sin(3 a) changes sign at k pi / 3, k = 1..5
    crossings = np.count_nonzero(np.diff(w > 10.0))
    assert crossings == 5
    np.testing.assert_array_equal(speed_with_ripple([4.0], [1.0], 0.0, 1.0), [4.0])


def test_sensor_validation_names_the_field_and_unit() -> None:
    with pytest.raises(ConfigError, match=r"sensors.torque.rate.*Hz"):
        TorqueMeter(rate=0.0)
    with pytest.raises(ConfigError, match=r"sensors.speed.ripple"):
        Encoder(ripple=float("nan"))
    with pytest.raises(ConfigError, match=r"scene: sensors.torque: unknown key\(s\) \['nois'\]"):
        sensors_from_mapping({"torque": {"nois": 1.0}}, "scene: sensors")
    with pytest.raises(ConfigError, match=r"unknown sensor\(s\) \['torq'\]"):
        sensors_from_mapping({"torq": {}}, "scene: sensors")
    with pytest.raises(ConfigError, match=r"sensors.preload.noise = '-1'"):
        sensors_from_mapping({"preload": {"noise": "-1"}}, "sensors")


def test_sensors_from_mapping_fills_defaults_and_reads_numbers_given_as_text() -> None:
    s = sensors_from_mapping({"torque": {"rate": "1e3"}}, "x")
    assert s.torque.rate == 1000.0
    assert s.speed == SensorSet().speed
    assert s.to_dict()["torque"]["rate"] == 1000.0
