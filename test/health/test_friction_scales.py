"""The unit's Eyring stress and mu_dry for the fault classes' responses (health/friction_scales)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from ballscrew_twin.errors import ConfigError
from ballscrew_twin.health.baseline import Baseline
from ballscrew_twin.health.friction_scales import (
    fit_friction_scales,
    friction_misfit,
    scaled_friction,
)
from ballscrew_twin.health.monitor import HealthMonitor
from ballscrew_twin.models.base import OperatingPoint
from ballscrew_twin.models.steady import SteadyStateModel
from ballscrew_twin.params import TwinConfig, load_config


@pytest.fixture(scope="module")
def paper() -> TwinConfig:
    return load_config(None)


def test_scaled_friction_changes_only_the_eyring_stress_and_mu_dry(paper: TwinConfig) -> None:
    assert scaled_friction(paper, 1.0, 1.0) is paper
    changed = scaled_friction(paper, 0.8, 1.25)
    assert changed.lubricant.eyring_stress == pytest.approx(0.8 * paper.lubricant.eyring_stress)
    assert changed.contact.dry_friction_coefficient == pytest.approx(
        1.25 * paper.contact.dry_friction_coefficient
    )
    back = replace(
        changed,
        lubricant=replace(changed.lubricant, eyring_stress=paper.lubricant.eyring_stress),
        contact=replace(
            changed.contact, dry_friction_coefficient=paper.contact.dry_friction_coefficient
        ),
    )
    assert back == paper
    for bad in (0.0, -1.0, float("nan")):
        with pytest.raises(ConfigError, match="must be > 0"):
            scaled_friction(paper, bad, 1.0)


def _cost(measured: np.ndarray, drag: np.ndarray) -> float:
    return float(np.sum(friction_misfit(measured, drag) ** 2))


def test_the_misfit_does_not_see_a_common_gain() -> None:
    drag = np.array([1.0, 2.0, 3.5, 5.0])
    other = np.array([1.0, 2.2, 3.0, 5.5])
    assert _cost(1.07 * drag, drag) == pytest.approx(0.0, abs=1e-24)
    assert _cost(other, 3.0 * drag) == pytest.approx(_cost(other, drag))
    assert _cost(other, drag) > 0.0


def _drags(model: SteadyStateModel, points: list[OperatingPoint], warmer: float) -> np.ndarray:
    """The steady drag [N m] at ``points`` read ``warmer`` [K] warmer."""
    moved = [replace(op, temperature=op.temperature + warmer) for op in points]
    return np.array([model.evaluate(op).drag_torque for op in moved])


def test_a_units_friction_is_found_from_its_steady_drag(paper: TwinConfig) -> None:
    """Block means of a unit with tau_e x 0.8 and mu_dry x 1.2, 2 K warmer than the main fit
    put it, read through a sensor gain of 1.04, without noise: the fit finds the three (the
    grid alone puts them at 0.7, 1.0 and 3 K, on the cost's valley), and explains the blocks
    far better than the nominal friction laws."""
    unit = SteadyStateModel(scaled_friction(paper, 0.8, 1.2))
    speeds = np.geomspace(2.5, 300.0, 8)
    points = [
        OperatingPoint(screw_speed=float(w * sign), temperature=t, preload=1500.0)
        for w in speeds
        for t, sign in ((278.15, 1.0), (303.15, -1.0))
    ]
    measured = 1.04 * _drags(unit, points, 2.0)
    eyring, dry = fit_friction_scales(measured, points, paper)
    assert eyring == pytest.approx(0.8, abs=0.01)
    assert dry == pytest.approx(1.2, abs=0.01)
    plain = _drags(SteadyStateModel(paper), points, 0.0)
    fitted = _drags(SteadyStateModel(scaled_friction(paper, eyring, dry)), points, 2.0)
    assert _cost(measured, fitted) < 0.1 * _cost(measured, plain)


def test_too_few_blocks_keep_the_nominal_friction(paper: TwinConfig) -> None:
    points = [OperatingPoint(screw_speed=10.0, temperature=293.15, preload=1500.0)] * 3
    assert fit_friction_scales(np.ones(3), points, paper) == (1.0, 1.0)


def test_the_monitor_judges_classes_by_the_units_friction(paper: TwinConfig) -> None:
    """The classes' responses come from the steady model at the commissioned scales; a
    nominal baseline keeps the monitor's own predictor."""
    plain = HealthMonitor(paper, baseline=Baseline.nominal(paper))
    assert plain.responses is plain.predictor
    unit = replace(Baseline.nominal(paper), eyring_scale=0.77, dry_friction_scale=1.2)
    monitor = HealthMonitor(paper, baseline=unit)
    assert monitor.responses.config == scaled_friction(paper, 0.77, 1.2)
    with pytest.raises(ConfigError, match="eyring_scale"):
        replace(unit, eyring_scale=0.0)
