"""The compiled dynamic step (kernels/dynamic_step.py) against the readable Python step.

Both integrate the same scene side by side from the same initial state through a preload and
speed ramp (contacts closing, stiff friction, Newton iterations with backtracking, Jacobians
kept and refreshed): the trajectories must agree to rounding, with and without defects.
"""

import dataclasses

import numpy as np
import pytest

from ballscrew_twin.kernels import (
    dynamic_layouts,
    dynamic_predictor,
    dynamic_run,
    dynamic_step,
    solver_settings,
)
from ballscrew_twin.models import dynamic
from ballscrew_twin.models.dynamic import DynamicModel
from ballscrew_twin.models.dynamic_state import Commands
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
        solver_settings.HELIX_NEWTON_STEPS,
        solver_settings.JACOBIAN_REFRESH_RATIO,
        solver_settings.PREDICTOR_ORDER,
        solver_settings.STEP_BACKTRACKS,
        solver_settings.STEP_NEWTON_MAX,
        solver_settings.STEP_TOLERANCE,
        solver_settings.VELOCITY_STEP,
    )


def test_the_run_loop_cache_stamps_the_step_it_calls() -> None:
    """The time loop's cached code calls the step kernel of another file: its stamp covers that
    file, its layouts and predictor, and is current once checked."""
    dynamic_run.ensure_fresh_cache()
    assert dynamic_run.compiled_stamp() == dynamic_run.DEPENDENCY_STAMP
    assert dynamic_run.DEPENDENCY_STAMP != dynamic_step.DEPENDENCY_STAMP
    assert dynamic_run.ensure_fresh_cache() is False  # checked once per process


@pytest.mark.parametrize(
    ("faults", "interval", "implicit"),
    [(Faults(), 1, False), (DEFECTS, 5, False), (Faults(), 1, True), (DEFECTS, 5, True)],
)
def test_compiled_step_follows_the_reference_trajectory(
    faults: Faults, interval: int, implicit: bool
) -> None:
    screw = dataclasses.replace(BASE.screw, balls_per_nut=2)
    config = dataclasses.replace(BASE, screw=screw)
    models = [
        DynamicModel(
            config,
            293.15,
            jacobian_interval=interval,
            faults=faults,
            compiled_step=compiled,
            implicit_positions=implicit,
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


def test_predictor_coefficients_are_those_of_the_reference() -> None:
    for compiled, reference in zip(
        dynamic_predictor.PREDICTOR_COEFFICIENTS, dynamic.PREDICTOR_COEFFICIENTS, strict=True
    ):
        assert compiled == reference + (0.0,) * (len(compiled) - len(reference))
    assert len(dynamic_predictor.PREDICTOR_COEFFICIENTS) == solver_settings.PREDICTOR_ORDER + 1


def _polynomial_velocities(
    order: int, count: int, steps: int
) -> list[tuple[np.ndarray, np.ndarray]]:
    """Sphere and shared velocities sampled on a polynomial of ``order`` in the step index."""
    rng = np.random.default_rng(order)
    a, b = rng.normal(size=(order + 1, count, 6)), rng.normal(size=(order + 1, 3))
    return [
        (sum(a[p] * k**p for p in range(order + 1)), sum(b[p] * k**p for p in range(order + 1)))
        for k in range(steps)
    ]


@pytest.mark.parametrize("order", [0, 1, 2, 3])
def test_predictor_finds_and_extrapolates_a_polynomial(order: int) -> None:
    """Velocities on a polynomial of degree ``order`` in time: after enough steps the predictor
    has chosen that order (the lowest exact one) and its guess is the next value, in the kernel
    and in the reference; a jammed sphere's rotation stays zero; a jump in time (a state that
    does not continue the last step) restarts from u_n."""
    count, dt, t0 = 3, 2e-6, 0.25
    model = DynamicModel(
        dataclasses.replace(BASE, screw=dataclasses.replace(BASE.screw, balls_per_nut=2)),
        293.15,
        time_step=dt,
        compiled_step=False,
    )
    consts = np.zeros(dynamic_layouts.N_CONST)
    consts[dynamic_layouts.K_DT] = dt
    consts[dynamic_layouts.K_BALL_RADIUS] = model.geometry.ball_radius
    consts[dynamic_layouts.K_PITCH_RADIUS] = model.geometry.pitch_radius
    history = np.zeros((solver_settings.PREDICTOR_ORDER, count + 1, 6))
    meta = np.array([np.nan, 0.0, 0.0])
    jammed = np.array([False, True, False])
    samples = _polynomial_velocities(order, count, 8)
    for u_k, _ in samples:
        u_k[1, 3:] = 0.0  # the step hands the predictor u_n with a jammed rotation at zero
    for k in range(len(samples) - 1):
        time = t0 + k * dt
        (u0, s0), (u1, s1) = samples[k], samples[k + 1]
        u, s = u0.copy(), s0.copy()
        extrapolated = dynamic_predictor.predict(u0, s0, time, jammed, history, meta, u, s)
        ref_u, ref_s, ref_extrapolated = model._predict(time, u0, s0, jammed)
        assert extrapolated == ref_extrapolated == (k >= 2 and model._history_order > 0)
        if k >= order + 1:  # the order has been found on the step before
            expected = u1
            for got_u, got_s in ((u, s), (ref_u, ref_s)):
                np.testing.assert_allclose(got_u, expected, rtol=1e-9, atol=1e-9)
                np.testing.assert_allclose(got_s, s1, rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(u, ref_u, rtol=1e-12, atol=1e-12)
        dynamic_predictor.remember(u0, s0, u1, s1, time, consts, history, meta)
        model._remember(time, u0, s0, u1, s1)
        assert meta[dynamic_layouts.H_ORDER] == model._history_order
    assert meta[dynamic_layouts.H_ORDER] == order
    (u0, s0) = samples[0]
    u, s = u0.copy(), s0.copy()
    assert not dynamic_predictor.predict(u0, s0, t0 + 1.0, jammed, history, meta, u, s)  # a jump
    np.testing.assert_array_equal(u, u0)
    np.testing.assert_array_equal(model._predict(t0 + 1.0, u0, s0, jammed)[0][0], u0[0])


@pytest.mark.parametrize("compiled", [False, True])
def test_predictor_leaves_the_converged_trajectory_unchanged(compiled: bool) -> None:
    """The predictor changes where Newton starts, not where it ends: the same ramp with and
    without it (history cleared before every step) agrees to the step tolerance, with fewer
    evaluations of the contact laws."""
    screw = dataclasses.replace(BASE.screw, balls_per_nut=2)
    config = dataclasses.replace(BASE, screw=screw)
    models = [
        DynamicModel(config, 293.15, jacobian_interval=5, compiled_step=compiled) for _ in (0, 1)
    ]
    states = [model.initial_state(0.0) for model in models]
    evaluations = [0, 0]
    for k in range(STEPS):
        ramp = min(k / 100.0, 1.0)
        commands = Commands(30.0 * ramp * ramp * (3.0 - 2.0 * ramp), 400.0 * ramp)
        models[1]._history_time = np.nan
        if models[1]._kernel is not None:
            models[1]._kernel.history_meta[0] = np.nan
        for n, model in enumerate(models):
            before = model.work["contact_evaluations"]
            states[n], _ = model.step(states[n], commands)
            evaluations[n] += model.work["contact_evaluations"] - before
    predicted, plain = states
    for name in ("ball_position", "ball_velocity", "ball_omega", "nut_velocity"):
        assert _relative(getattr(predicted, name), getattr(plain, name)) < 1e-5, name
    assert _relative(predicted.screw_speed, plain.screw_speed) < 1e-6
    if compiled:  # the Python step does not count its work
        assert evaluations[0] < evaluations[1], evaluations
