"""How long the monitor refines the class of an alarm: a class two faults explain alike at one
operating point stays open until the operating point moves, up to the patience."""

from __future__ import annotations

import numpy as np

from ballscrew_twin.health.fault_profiles import FaultedTwin, FaultState
from ballscrew_twin.health.monitor import HealthMonitor, MonitorSettings, feed
from ballscrew_twin.health.residuals import UnitTwin
from ballscrew_twin.models.base import OperatingPoint
from ballscrew_twin.params import load_config

from .synthetic import PRELOAD, TEMPERATURE, bench_channels

ONSET = 20.0  # s
MOVE = 32.0  # s


def _jam_then_a_speed_change():
    """A unit equal to the twin at 20 C / 1500 N, at 5 rad/s until MOVE, then 150 rad/s (a
    0.5 s ramp); from ONSET on a jam (mu_dry and roughness x1.5) changes its drag by the
    steady model's ratio: +27 % at 5 rad/s, where a thinner oil also raises the torque, and
    -5 % at 150 rad/s, where a thinner oil lowers it more. Torque meter 1 kHz, 0.2 mN m."""
    config = load_config(None)
    twin = UnitTwin(config)
    steady = FaultedTwin(config)
    jam = FaultState(dry_friction_factor=1.5, roughness_factor=1.5)

    def ratio(speed: float) -> float:
        op = OperatingPoint(
            screw_speed=speed, temperature=TEMPERATURE, preload=PRELOAD, axial_load=0.0
        )
        return steady.drag_torque(op, jam) / steady.drag_torque(op, FaultState())

    slow, fast = 5.0, 150.0
    t = np.arange(0.0, 50.0, 1e-3)
    w = slow + (fast - slow) * np.clip((t - MOVE) / 0.5, 0.0, 1.0)
    change = ratio(slow) + (ratio(fast) - ratio(slow)) * (w - slow) / (fast - slow)
    drag = twin.drag(w, TEMPERATURE, PRELOAD) * np.where(t >= ONSET, change, 1.0)
    torque = drag + config.screw.screw_inertia * np.gradient(w, t)
    torque = torque + np.random.default_rng(3).normal(0.0, 2e-4, len(t))
    return config, twin, bench_channels(t, torque, w)


def test_an_unsure_class_is_refined_until_the_operating_point_moves() -> None:
    config, twin, channels = _jam_then_a_speed_change()
    monitor = HealthMonitor(config, MonitorSettings(), twin=twin)
    feed(monitor, channels)
    alarm = monitor.alarm
    assert alarm is not None and ONSET < alarm.time < ONSET + 1.0
    # at 5 rad/s a jam and a thinner oil fit alike: refined past the 8 s window ...
    unsure = [c for t, c in monitor.classifications if t < MOVE]
    assert unsure and all(c.confidence < 0.9 for c in unsure)
    # ... until 150 rad/s tells them apart
    assert alarm.final
    assert alarm.classification.fault_class == "jam_onset"
    assert alarm.classification.confidence >= 0.9
    # with no patience beyond the window the class is kept unsure
    hasty = HealthMonitor(config, MonitorSettings(classification_patience=8.0), twin=twin)
    feed(hasty, channels)
    assert hasty.alarm is not None and hasty.alarm.final
    assert hasty.alarm.classification.confidence < 0.9
