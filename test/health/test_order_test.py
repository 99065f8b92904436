"""The monitor's order test on a duty cycle that reverses: a defect's ripple (the generator's
parametric model, which opposes the motion like the drag) is found through the reversals and
names its class, also when a mean-shift test alarms first."""

from __future__ import annotations

import numpy as np
import pytest

from ballscrew_twin.health.classify import defect_orders
from ballscrew_twin.health.detectors import centred_acceleration
from ballscrew_twin.health.fault_profiles import ripple_torque
from ballscrew_twin.health.monitor import HealthMonitor, feed
from ballscrew_twin.health.monitor_settings import MonitorSettings
from ballscrew_twin.health.residuals import UnitTwin
from ballscrew_twin.params import load_config

from .synthetic import bench_channels

ONSET = 30.0  # s


def _measured(t, w, friction: float, ripple: float, kind: str, seed: int):
    """A unit equal to the twin at 20 C / 1500 N at speeds ``w`` [rad/s] at instants ``t``
    [s], with a ``kind`` ripple of peak ``ripple`` (a fraction of the drag) and its friction
    times ``friction`` from ONSET on. Torque meter 1 kHz, 0.2 mN m noise."""
    config = load_config(None)
    twin = UnitTwin(config)
    drag = twin.drag(w, 293.15, 1500.0) * np.where(t >= ONSET, friction, 1.0)
    size = np.where(t >= ONSET, ripple, 0.0)
    zero = np.zeros_like(t)
    raceway, sphere = (size, zero) if kind == "raceway_defect" else (zero, size)
    torque = drag + ripple_torque(config, t, w, drag, raceway, sphere)
    torque = torque + config.screw.screw_inertia * np.gradient(w, t)
    torque = torque + np.random.default_rng(seed).normal(0.0, 2e-4, len(t))
    return config, twin, bench_channels(t, torque, w)


def _reversing(
    ripple: float, kind: str, duration: float = 50.0, friction: float = 1.0, period: float = 2.0
):
    """:func:`_measured` on a trapezoidal cycle of +-60 rad/s that reverses every half
    ``period`` [s] (ramps of a fifth of it)."""
    t = np.arange(0.0, duration, 1e-3)
    phase = np.mod(t, period) * 2.0 / period
    w = 60.0 * np.clip(5.0 * np.minimum(phase, 2.0 - phase) - 2.5, -1.0, 1.0)
    return _measured(t, w, friction, ripple, kind, seed=11)


def _short_strokes(ripple: float, kind: str, duration: float = 40.0):
    """:func:`_measured` on a sinusoidal position command at 0.7 Hz, peak speed 22 rad/s:
    strokes of 1.6 turns back and forth over the same turns (an EMA's small oscillation).
    Dev unit 16012 (round 17 of issue 13) missed a 4 % sphere spot on such a sine of 1.5
    turns' stroke: a window had to span 4 turns, and none was tested; strokes back and forth
    over the same turns add up in the transform, and the line stands out at once (ratio
    70-130 against 25)."""
    t = np.arange(0.0, duration, 1e-3)
    w = 22.0 * np.sin(2.0 * np.pi * 0.7 * t)
    return _measured(t, w, 1.0, ripple, kind, seed=12)


#: The order test alone, as the ripple tests run it.
SPECTRAL = MonitorSettings(detectors=("spectral",))


@pytest.fixture(scope="module")
def healthy_alarms() -> dict[str, object]:
    """The order test's alarm on each cycle without a defect, run once per cycle: with no
    ripple the recording is the same for both kinds of defect (checked here), so the tests of
    both kinds check the one run."""
    alarms: dict[str, object] = {}
    for cycle, make in (("reversing", _reversing), ("short_strokes", _short_strokes)):
        config, twin, channels = make(0.0, "raceway_defect")
        _, _, other = make(0.0, "sphere_defect")
        for name, (t, values) in channels.items():
            assert np.array_equal(t, other[name][0]) and np.array_equal(values, other[name][1])
        healthy = HealthMonitor(config, SPECTRAL, twin=twin)
        feed(healthy, channels)
        alarms[cycle] = healthy.alarm
    return alarms


@pytest.mark.parametrize("kind", ["raceway_defect", "sphere_defect"])
@pytest.mark.parametrize("cycle", ["reversing", "short_strokes"])
def test_a_small_ripple_is_found_through_reversals(
    cycle: str, kind: str, healthy_alarms: dict[str, object]
) -> None:
    make = _reversing if cycle == "reversing" else _short_strokes
    config, twin, channels = make(0.02, kind)
    monitor = HealthMonitor(config, SPECTRAL, twin=twin)
    feed(monitor, channels)
    assert monitor.alarm is not None
    assert ONSET < monitor.alarm.time <= ONSET + 5.0
    assert monitor.alarm.classification.fault_class == kind
    # the same cycle without the defect: no alarm
    assert healthy_alarms[cycle] is None


def test_a_ripple_found_by_the_mean_shift_test_is_named_by_its_order() -> None:
    # a raised-cosine ripple of peak 30 % raises the mean friction by 15 % in both directions
    # (5 sigmas of the nominal twin's error): the CUSUM, oriented by the direction of the
    # friction, sees that within a stroke, and the class comes from the order line seen since
    config, twin, channels = _reversing(0.30, "raceway_defect")
    monitor = HealthMonitor(config, MonitorSettings(detectors=("cusum",)), twin=twin)
    feed(monitor, channels)
    assert monitor.alarm is not None and monitor.alarm.detector == "cusum"
    assert ONSET < monitor.alarm.time <= ONSET + 1.0
    assert monitor.alarm.classification.fault_class == "raceway_defect"


def test_a_friction_change_accumulates_through_reversals() -> None:
    # 15 % less friction: 5 sigmas of the nominal twin's 3 % error, a residual that changes
    # sign at every reversal (every 0.6 s). Oriented by the friction's direction the CUSUM
    # adds it up over the strokes; unoriented, every stroke undid the last (no alarm in 20 s).
    # (10 % until round 5 of issue 13: the tracker then read 30 s of the twin's error at two
    # operating points as 300 independent blocks and was sure of the friction scale to well
    # under 3 %; updated as the shared error it is, the uncommissioned twin's friction scale
    # stays as uncertain as its 3 % error after 30 s, and a 10 % change is 2.3 innovation
    # sigmas, under the CUSUM's k = 2.5 of then; 2 since round 41.)
    config, twin, channels = _reversing(0.0, "raceway_defect", friction=0.85, period=1.2)
    monitor = HealthMonitor(config, MonitorSettings(detectors=("cusum",)), twin=twin)
    feed(monitor, channels)
    assert monitor.alarm is not None
    assert ONSET < monitor.alarm.time <= ONSET + 5.0
    assert monitor.alarm.classification.fault_class == "preload_loss"


def test_the_encoder_ripple_near_the_block_rate_makes_no_order_line() -> None:
    # Held-out unit 13028 (round 14 of issue 13) at 63.45 rad/s: the drive's speed ripple of
    # one period a revolution, 10.1 Hz, is nearly one period a 0.1 s block. An inertia torque
    # fitted to each block alone repeated from block to block, jumped at the block edges and
    # made a 50 Hz line, order 4.95 at that speed, against the sphere spin order 4.94: a
    # false alarm. Here the speed puts 50 Hz on the spin order exactly; the acceleration the
    # monitor subtracts is continuous from block to block, and no order line is seen.
    config, twin = load_config(None), UnitTwin(load_config(None))
    spin = defect_orders(config)["sphere_spin"]
    mean_speed = 2.0 * np.pi * 50.0 / spin  # rad/s
    t = np.arange(0.0, 40.0, 1e-3)
    angle = mean_speed * t
    w = mean_speed * (1.0 + 0.005 * np.sin(angle))
    rng = np.random.default_rng(5)
    torque = twin.drag(w, 293.15, 1500.0) + config.screw.screw_inertia * np.gradient(w, t)
    torque = torque + rng.normal(0.0, 2e-4, len(t))
    measured_speed = w + rng.normal(0.0, 0.01, len(t))
    monitor = HealthMonitor(config, MonitorSettings(detectors=("spectral",)), twin=twin)
    statistics = [
        s.statistics["spectral"][0]
        for s in feed(monitor, bench_channels(t, torque, measured_speed))
        if "spectral" in s.statistics
    ]
    assert monitor.alarm is None
    assert max(statistics) < 0.5 * monitor.order.test.threshold


def test_the_acceleration_is_the_centred_slope_of_the_speed() -> None:
    # Oracle: for a quadratic speed the least-squares slope over a window centred on a sample
    # is the derivative there exactly; where a ramp ends, the estimate is back to zero half a
    # window after its end (not a block later: held-out unit 14029, round 15 of issue 13).
    t = np.arange(0.0, 0.3, 1e-3)
    w = 40.0 * t**2 - 3.0 * t + 1.0
    slope = centred_acceleration(t, w, 0.05)
    inside = slice(25, len(t) - 25)
    assert np.allclose(slope[inside], 80.0 * t[inside] - 3.0, rtol=0.0, atol=1e-9)
    ramp = np.minimum(t, 0.1) * 190.0  # rad/s: 190 rad/s^2 until 0.1 s, then constant
    slope = centred_acceleration(t, ramp, 0.05)
    assert np.allclose(slope[t <= 0.07], 190.0, atol=1e-9)
    assert np.allclose(slope[(t >= 0.1255) & (t < 0.27)], 0.0, atol=1e-9)
    # Two samples: the slope of the line through them at both; fewer: no slope, no error.
    two = centred_acceleration(t[:2], np.array([1.0, 1.5]), 0.05)
    assert np.allclose(two, 0.5 / 1e-3, rtol=1e-12)
    assert centred_acceleration(t[:1], w[:1], 0.05).tolist() == [0.0]
    assert centred_acceleration(t[:0], w[:0], 0.05).tolist() == []
