"""The compiled dynamic step (kernels/dynamic_step.py) against the readable Python step.

Both integrate the same scene side by side from the same initial state through a preload and
speed ramp (contacts closing, stiff friction, Newton iterations with backtracking, Jacobians
kept and refreshed): the trajectories must agree to rounding, with and without defects.
"""

import dataclasses

import numpy as np
import pytest

from ballscrew_twin.kernels import dynamic_step
from ballscrew_twin.models import dynamic
from ballscrew_twin.models.dynamic import Commands, DynamicModel
from ballscrew_twin.models.faults import Faults, RacewaySpall, SphereDefect, SphereJam
from ballscrew_twin.params import load_config

BASE = load_config()
STEPS = 300
DEFECTS = Faults(
    spheres=(SphereDefect(nut=1, index=1, radius_change=2e-6),),
    spalls=(
        RacewaySpall(half_groove="S2", centre=0.2, width=0.4, depth=3e-6),
        RacewaySpall(half_groove="N1", centre=-12.0, width=1.0, depth=2e-6),
    ),
    jams=(SphereJam(nut=0, index=1, start=1.5e-4),),  # half-way through the run
)


def _relative(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.max(np.abs(np.asarray(a) - np.asarray(b))) / (np.max(np.abs(b)) + 1e-300))


def test_frozen_constants_are_those_of_the_reference() -> None:
    assert dynamic_step.frozen_constants() == (
        dynamic.HELIX_NEWTON_STEPS,
        dynamic.JACOBIAN_REFRESH_RATIO,
        dynamic.STEP_BACKTRACKS,
        dynamic.STEP_NEWTON_MAX,
        dynamic.STEP_TOLERANCE,
        dynamic.VELOCITY_STEP,
    )


@pytest.mark.parametrize(("faults", "interval"), [(Faults(), 1), (DEFECTS, 5)])
def test_compiled_step_follows_the_reference_trajectory(faults: Faults, interval: int) -> None:
    screw = dataclasses.replace(BASE.screw, balls_per_nut=2)
    config = dataclasses.replace(BASE, screw=screw)
    models = [
        DynamicModel(
            config, 293.15, jacobian_interval=interval, faults=faults, compiled_step=compiled
        )
        for compiled in (False, True)
    ]
    states = [model.initial_state(0.0) for model in models]
    worst = 0.0
    for k in range(STEPS):
        ramp = min(k / 100.0, 1.0)
        commands = Commands(30.0 * ramp * ramp * (3.0 - 2.0 * ramp), 400.0 * ramp)
        (ref, ref_report), (fast, fast_report) = (
            model.step(state, commands) for model, state in zip(models, states, strict=True)
        )
        states = [ref, fast]
        for name in ("ball_position", "ball_velocity", "ball_omega", "nut_velocity"):
            worst = max(worst, _relative(getattr(fast, name), getattr(ref, name)))
        worst = max(
            worst,
            _relative(fast.screw_speed, ref.screw_speed),
            _relative(fast_report.motor_torque, ref_report.motor_torque),
            _relative(fast_report.dissipation, ref_report.dissipation),
            _relative(fast_report.nut_force, ref_report.nut_force),
            _relative(fast_report.mechanism_dissipation, ref_report.mechanism_dissipation),
            _relative(fast_report.nut_dissipation, ref_report.nut_dissipation),
            _relative(fast_report.contacts.groove_force, ref_report.contacts.groove_force),
        )
        np.testing.assert_array_equal(fast_report.contacts.active, ref_report.contacts.active)
    assert worst < 1e-9, worst
    assert models[1].unconverged_steps == models[0].unconverged_steps
    # The scene did something: contacts loaded and the screw turning.
    assert ref_report.contacts.active.any() and ref.screw_speed > 1.0
    if faults.jams:
        np.testing.assert_array_equal(fast.ball_omega[1], 0.0)
        assert np.all(np.abs(ref.ball_omega[0]) > 0.0)
