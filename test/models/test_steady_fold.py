"""Past a fold of the start-up path (issue 14, item 2; docs/model.md 7a, "Past a fold"): where
the path's state ends, the cold solve takes the state the curve of steady states reaches past
the fold, not the one a Newton jump happens to land on."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ballscrew_twin.models.base import OperatingPoint
from ballscrew_twin.models.steady import SteadyStateModel
from ballscrew_twin.models.steady_fold import PAST, _Curve, _pack, follow_fold
from ballscrew_twin.models.steady_types import SteadyState
from ballscrew_twin.params import TwinConfig, default_config_path, load_config

RPM = 2 * math.pi / 60
SCREW = default_config_path().parent / "screw_32x10.yaml"
#: 0.16 C [K]: the 32 mm screw's master nut ends a state at a fold near 69-114 rpm at 15-30 N.
COLD = 273.31


@pytest.fixture(scope="module")
def screw() -> TwinConfig:
    return load_config(SCREW)


def master_rate(state: SteadyState) -> float:
    """The master nut's sphere's orbital rate over the screw speed [-] (-1: it travels with its
    nut; about -0.55: it rolls on both grooves)."""
    return float(state.kinematics[0, 0] / state.screw_speed)


def test_the_start_up_state_is_one_state_across_the_preloads(screw: TwinConfig) -> None:
    """At 407.5 rpm the start-up path ends its state at a fold at every preload of 16-22 N.
    The Newton jump from there landed on the rolling state at 17, 18.5 and 20 N and on the
    state travelling with the nut at the others (measured before this change: drag 9.30,
    10.35 and 11.39 mN m there against 8.94, 9.49 and 10.59 at 18, 19 and 21 N); past the
    fold the curve reaches the travelling state at every preload, and the drag rises with the
    preload."""
    model = SteadyStateModel(screw, mode="symmetric")
    rates, drags = [], []
    for preload in np.arange(16.0, 22.01, 0.5):
        model.forget_warm_start()
        op = OperatingPoint(screw_speed=407.5 * RPM, temperature=COLD, preload=float(preload))
        solution = model.solve(op)
        rates.append(master_rate(solution.state))
        drags.append(solution.output.drag_torque)
    assert np.all(np.abs(np.array(rates) + 1.0) < 0.05), rates
    assert np.all(np.diff(drags) > 0.0), drags


def test_the_curve_goes_around_the_fold_to_the_travelling_state(screw: TwinConfig) -> None:
    """17 N: followed up in small warm steps, the rolling-to-travelling state ends at a fold
    near 68.8 rpm (the next step leaves it). From its last state the curve turns back in speed
    and forward again (an S) and passes the fold on the state travelling with the nut: a
    solution of the readable reference's balance there, above the fold speed (before the fold
    rule the path's Newton jump from there landed on the rolling state, w_B / Omega -0.18)."""
    model = SteadyStateModel(screw, mode="symmetric", branch="path")
    states: list[SteadyState] = []
    speed = 66.0 * RPM
    while True:
        op = OperatingPoint(screw_speed=speed, temperature=COLD, preload=17.0)
        state = model.solve(op).state
        if states and abs(master_rate(state) - master_rate(states[-1])) > 0.02:
            break
        states.append(state)
        speed *= 1.001
    assert 60.0 * RPM < states[-1].screw_speed < 75.0 * RPM
    balls = model.ball_set("symmetric")
    loads = model.nut_axial_loads(op)
    landed = follow_fold(model, op, balls, loads, states[-1])
    assert landed is not None
    assert landed.screw_speed > PAST * states[-1].screw_speed
    assert abs(master_rate(landed) + 1.0) < 0.01
    reference = SteadyStateModel(screw, mode="symmetric", backend="reference")
    scene = reference.scene(COLD, landed.screw_speed)
    spheres, _, nuts, _ = reference._reference.residual(scene, balls, landed, loads)
    assert max(np.max(np.abs(spheres)), np.max(np.abs(nuts))) < 1e-8


def test_a_problem_of_more_spheres_than_one_per_nut_is_not_followed(screw: TwinConfig) -> None:
    model = SteadyStateModel(screw, mode="full")
    op = OperatingPoint(screw_speed=50.0 * RPM, temperature=COLD, preload=500.0)
    state = model.solve(op).state
    balls = model.ball_set("full")
    assert follow_fold(model, op, balls, model.nut_axial_loads(op), state) is None


def test_the_compiled_curve_jacobian_is_the_readable_ones_difference(screw: TwinConfig) -> None:
    """The curve's Jacobian from the compiled sphere blocks equals the forward differences of
    the readable reference's residual (the definition) at a state near a fold, to the
    differences' own error; the residuals agree to rounding."""
    op = OperatingPoint(screw_speed=68.0 * RPM, temperature=COLD, preload=17.0)
    compiled = SteadyStateModel(screw, mode="symmetric", branch="path")
    reference = SteadyStateModel(screw, mode="symmetric", backend="reference")
    state = compiled.solve(op).state
    balls = compiled.ball_set("symmetric")
    loads = compiled.nut_axial_loads(op)
    y = _pack(state)
    fast, readable = _Curve(compiled, op, balls, loads), _Curve(reference, op, balls, loads)
    assert fast.compiled and not readable.compiled
    np.testing.assert_allclose(fast.residual(y), readable.residual(y), rtol=0, atol=1e-12)
    exact, differenced = fast.jacobian(y), readable.jacobian(y)
    scale = np.max(np.abs(differenced), axis=1, keepdims=True)
    assert np.max(np.abs(exact - differenced) / scale) < 1e-4
    assert np.count_nonzero(exact[:, :-1]) == np.count_nonzero(differenced[:, :-1])
