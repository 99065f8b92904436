"""The structured compiled steady solver equals the readable reference.

Oracles:
- the sphere Jacobian blocks computed by forward mode (dual numbers) against central differences
  of the plain residuals (relative 1e-5 of each block's scale: the difference quotient's own
  error), and their value part against the plain residuals (bit for bit);
- the plain residuals against the reference model's ``_residual`` (numpy contact laws);
- whole solves against ``SteadyStateModel(backend="reference")`` (numpy contact laws, Python
  Newton with a central-difference Jacobian) over the envelope: speed (both signs, standstill),
  temperature (-40..100 C), preload (0..5000 N), axial load, symmetric and full mode, cold and
  along a warm-started path. Drag torque, nut torques and mechanism breakdown to 1e-9 relative.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from ballscrew_twin.errors import SolverError
from ballscrew_twin.kernels import solver_settings, steady_solver
from ballscrew_twin.kernels.contacts import N_ROWS, contacts_kernel, scene_arrays
from ballscrew_twin.kernels.steady_linear import lu_factor, lu_solve
from ballscrew_twin.kernels.steady_solver import (
    DEPENDENCY_STAMP,
    compiled_stamp,
    ensure_fresh_cache,
    frozen_constants,
)
from ballscrew_twin.kernels.steady_sphere import linearise, residuals
from ballscrew_twin.models import steady
from ballscrew_twin.models.base import MECHANISMS, ContactStates, OperatingPoint
from ballscrew_twin.models.steady import SteadySolution, SteadyState, SteadyStateModel
from ballscrew_twin.models.steady_compiled import kernel_inputs, predicted_start
from ballscrew_twin.models.steady_output import assemble
from ballscrew_twin.models.steady_problem import initial_state, residual_scales
from ballscrew_twin.params import TwinConfig, load_config
from ballscrew_twin.physics.contact_types import ContactEvaluation

RPM = 2.0 * math.pi / 60.0
RTOL = 1e-9


def operating_point(
    rpm: float, celsius: float, preload: float, axial_load: float = 0.0
) -> OperatingPoint:
    return OperatingPoint(
        screw_speed=rpm * RPM,
        temperature=celsius + 273.15,
        preload=preload,
        axial_load=axial_load,
    )


@pytest.fixture(scope="module")
def config() -> TwinConfig:
    return load_config()


def assert_same_solution(got: SteadySolution, ref: SteadySolution) -> None:
    out, expected = got.output, ref.output
    scale = max(abs(expected.drag_torque), 1e-300)
    assert out.drag_torque == pytest.approx(expected.drag_torque, rel=RTOL, abs=0)
    np.testing.assert_allclose(out.nut_torque, expected.nut_torque, rtol=RTOL, atol=RTOL * scale)
    for name in MECHANISMS:
        got_part = getattr(out.breakdown, name)
        assert got_part == pytest.approx(getattr(expected.breakdown, name), abs=RTOL * scale)
    for name in ("ball_nb", "kinematics", "nut_offset"):
        want = getattr(ref.state, name)
        size = float(np.max(np.abs(want), initial=0.0))
        np.testing.assert_allclose(
            getattr(got.state, name), want, rtol=1e-7, atol=1e-7 * size, err_msg=name
        )
    assert got.contacts.active.tolist() == ref.contacts.active.tolist()
    assert got.residual < 1e-10


# ----------------------------------------------------------------------------- compiled constants
def test_frozen_constants_are_the_current_ones() -> None:
    ensure_fresh_cache()
    assert frozen_constants() == (
        solver_settings.NEWTON_MAX_ITER,
        solver_settings.LINE_SEARCH_STEPS,
        solver_settings.MIN_STEP,
        solver_settings.DIAGONAL_SHIFT,
        steady_solver.CHORD_DECREASE,
        steady_solver.CHORD_POLISH,
        steady_solver.NEWTON_FINAL,
        steady_solver.CHORD_SLOW,
    )
    assert compiled_stamp() == DEPENDENCY_STAMP
    assert ensure_fresh_cache() is False  # checked once per process


def test_lu_factors_solve_as_numpy_and_flag_singular_blocks() -> None:
    rng = np.random.default_rng(7)
    for _ in range(20):
        a = rng.normal(size=(6, 6)) * 10.0 ** rng.integers(-6, 7, size=6)[:, None]
        factors, perm = a.copy(), np.empty(6, dtype=np.int64)
        assert lu_factor(factors, perm)
        for _ in range(2):  # the factors serve several right-hand sides
            rhs, x = rng.normal(size=6), np.empty(6)
            lu_solve(factors, perm, rhs, x)
            np.testing.assert_allclose(x, np.linalg.solve(a, rhs), rtol=1e-9, atol=1e-12)
    singular = rng.normal(size=(6, 6))
    singular[:, 3] = 0.0
    assert not lu_factor(singular.copy(), np.empty(6, dtype=np.int64))


# ----------------------------------------------------------------------------- residual, Jacobian
def _records(count: int) -> tuple[np.ndarray, np.ndarray]:
    """Output arrays of ``residuals``: active contacts, contact buffer."""
    return np.zeros((count, 4), dtype=bool), np.zeros((N_ROWS, count, 4))


def _problem(config: TwinConfig, mode: str, point: OperatingPoint):  # type: ignore[no-untyped-def]
    """A state near the solution of ``point`` and the arguments of the residual kernels."""
    model = SteadyStateModel(config, mode=mode)  # type: ignore[arg-type]
    solution = model.solve(point)
    scene = model.scene(point.temperature, point.screw_speed)
    balls = solution.balls
    loads = model.nut_axial_loads(point)
    force, moment = residual_scales(config, scene, loads)
    scales = (force, moment, force * config.screw.balls_per_nut)
    rng = np.random.default_rng(3)
    state = solution.state
    count = len(balls.nut)
    z = np.concatenate([state.ball_nb, state.kinematics], axis=1)
    z[:, :2] += rng.normal(scale=1e-8, size=(count, 2))
    z[:, 2:] *= 1.0 + rng.normal(scale=1e-3, size=(count, 4))
    e = state.nut_offset + rng.normal(scale=1e-8, size=2)
    args = (
        balls.nut,
        balls.weight,
        np.ascontiguousarray(balls.gravity),
        loads,
        scales,
        True,
        np.array(scene_arrays(scene)),
    )
    return model, scene, balls, z, e, args


@pytest.mark.parametrize("mode", ["symmetric", "full"])
def test_residuals_are_those_of_the_reference_model(config: TwinConfig, mode: str) -> None:
    point = operating_point(1000.0, -20.0, 800.0, axial_load=300.0)
    model, scene, balls, z, e, args = _problem(config, mode, point)
    res = np.empty((len(z), 6))
    nut_res = residuals(z, e, *args, res, *_records(len(z)))
    state = SteadyState(z[:, :2].copy(), z[:, 2:].copy(), e, scene.screw_speed)
    reference = SteadyStateModel(config, mode=mode, backend="reference")  # type: ignore[arg-type]
    ref_res, _, ref_nut, _ = reference._reference.residual(
        scene, balls, state, model.nut_axial_loads(point)
    )
    np.testing.assert_allclose(res, ref_res, rtol=1e-9, atol=1e-12 * np.abs(ref_res).max())
    np.testing.assert_allclose(nut_res, ref_nut, rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("mode", ["symmetric", "full"])
@pytest.mark.parametrize("rpm", [300.0, -2000.0])
def test_forward_mode_blocks_equal_difference_quotients(
    config: TwinConfig, mode: str, rpm: float
) -> None:
    point = operating_point(rpm, 40.0, 1200.0)
    _, _, _, z, e, args = _problem(config, mode, point)
    count = len(z)
    res, axial, jac = np.empty((count, 6)), np.empty(count), np.empty((count, 7, 7))
    nut_res = linearise(z, e, *args, res, axial, jac)
    plain = np.empty((count, 6))
    assert np.array_equal(residuals(z, e, *args, plain, *_records(count)), nut_res)
    assert np.array_equal(plain, res)  # the value part is the plain evaluation

    def rows(zz: np.ndarray, ee: np.ndarray) -> np.ndarray:
        """(B, 7): scaled residual rows and weighted axial push of every sphere (value parts)."""
        out, push, scratch = np.empty((count, 6)), np.empty(count), np.empty((count, 7, 7))
        linearise(zz, ee, *args, out, push, scratch)
        return np.concatenate([out, push[:, None]], axis=1)

    steps = [1e-10, 1e-10] + [1e-6 * abs(point.screw_speed)] * 4 + [1e-10]
    for c in range(7):
        zp, zm, ep, em = z.copy(), z.copy(), e.copy(), e.copy()
        if c < 6:  # spheres are independent given the nut offsets: all move at once
            zp[:, c] += steps[c]
            zm[:, c] -= steps[c]
        else:
            ep += steps[c]
            em -= steps[c]
        quotient = (rows(zp, ep) - rows(zm, em)) / (2.0 * steps[c])
        for i in range(count):
            scale = np.abs(jac[i]).max(axis=1)  # per row
            assert np.all(np.abs(jac[i, :, c] - quotient[i]) <= 1e-5 * scale), (i, c)


# ----------------------------------------------------------------------------- whole solves
ENVELOPE = {
    "20C-100rpm-1500N": (100.0, 20.0, 1500.0, 0.0),
    "-40C-3000rpm-5000N": (3000.0, -40.0, 5000.0, 0.0),
    "100C-6000rpm-300N": (6000.0, 100.0, 300.0, 0.0),
    "60C--1500rpm-2500N": (-1500.0, 60.0, 2500.0, 0.0),
    "0C-500rpm-1000N+800N": (500.0, 0.0, 1000.0, 800.0),
    "20C-200rpm-800N-2000N": (200.0, 20.0, 800.0, -2000.0),
    "20C-0rpm-1500N": (0.0, 20.0, 1500.0, 0.0),
    "20C-100rpm-0N": (100.0, 20.0, 0.0, 0.0),
    "30C-1000rpm-100N": (1000.0, 30.0, 100.0, 0.0),
}


@pytest.mark.parametrize("name", list(ENVELOPE))
def test_symmetric_solves_equal_the_reference(config: TwinConfig, name: str) -> None:
    point = operating_point(*ENVELOPE[name])
    ref = SteadyStateModel(config, mode="symmetric", backend="reference").solve(point)
    got = SteadyStateModel(config, mode="symmetric").solve(point)
    assert_same_solution(got, ref)


@pytest.mark.parametrize("name", ["20C-100rpm-1500N", "60C--1500rpm-2500N", "0C-500rpm-1000N+800N"])
def test_full_solves_equal_the_reference(config: TwinConfig, name: str) -> None:
    point = operating_point(*ENVELOPE[name])
    ref = SteadyStateModel(config, mode="full", backend="reference").solve(point)
    got = SteadyStateModel(config, mode="full").solve(point)
    assert_same_solution(got, ref)


@pytest.mark.parametrize("mode", ["symmetric", "full"])
def test_warm_started_path_equals_cold_reference_solves(config: TwinConfig, mode: str) -> None:
    """A path through speed, temperature, preload and load, each point warm-started from the
    last (reused Jacobian blocks), against the readable Newton solving each point afresh."""
    path = [
        (100.0, 20.0, 1500.0, 0.0),
        (110.0, 21.0, 1550.0, 0.0),
        (400.0, 25.0, 1550.0, 200.0),
        (400.0, 45.0, 900.0, 200.0),
        (-400.0, 45.0, 900.0, 0.0),
        (0.0, 45.0, 900.0, 0.0),
        (2500.0, 10.0, 3000.0, -500.0),
    ]
    model = SteadyStateModel(config, mode=mode)  # type: ignore[arg-type]
    for values in path:
        point = operating_point(*values)
        reference = SteadyStateModel(config, mode=mode, backend="newton")  # type: ignore[arg-type]
        assert_same_solution(model.solve(point), reference.solve(point))


def test_inertia_free_reduction_equals_the_reference(config: TwinConfig) -> None:
    point = operating_point(4000.0, 20.0, 1000.0)
    ref = SteadyStateModel(
        config, mode="symmetric", backend="reference", inertial_terms=False
    ).solve(point)
    got = SteadyStateModel(config, mode="symmetric", inertial_terms=False).solve(point)
    assert_same_solution(got, ref)


# ----------------------------------------------------------------------------- results
@pytest.mark.parametrize("mode", ["symmetric", "full"])
@pytest.mark.parametrize("rpm", [700.0, 0.0])
def test_contacts_recorded_in_the_solve_are_those_of_the_contact_kernel(
    config: TwinConfig, mode: str, rpm: float
) -> None:
    """The solver records the contacts while it evaluates the residuals (active ones) and
    completes them at the end (inactive ones, gravity and inertia): the buffer must be the
    contact kernel's at the returned state, to the last bit."""
    point = operating_point(rpm, 10.0, 900.0, axial_load=400.0)  # both nuts, both flanks
    model = SteadyStateModel(config, mode=mode)  # type: ignore[arg-type]
    model.solve(operating_point(rpm * 1.1, 12.0, 950.0))
    solution = model.solve(point)  # warm: recorded by residuals()
    state, balls = solution.state, solution.balls
    scene = model.scene(point.temperature, point.screw_speed)
    count = len(balls.nut)
    active, buffer = contacts_kernel(
        np.ascontiguousarray(state.ball_nb),
        np.ascontiguousarray(state.kinematics),
        state.nut_offset[balls.nut],
        balls.gravity,
        np.zeros((0, 3)),
        np.zeros(count),
        np.zeros((0, 4)),
        False,
        *scene_arrays(scene),
    )
    source = solution.contact_source
    assert not isinstance(source, ContactEvaluation)
    assert not active.all() and active.any()
    np.testing.assert_array_equal(source.active, active)
    np.testing.assert_array_equal(source.buffer, buffer)


@pytest.mark.parametrize("mode", ["symmetric", "full"])
@pytest.mark.parametrize("rpm", [-1500.0, 0.0])
def test_outputs_summed_in_the_kernel_equal_those_summed_in_python(
    config: TwinConfig, mode: str, rpm: float
) -> None:
    """Torques, breakdown, per-contact states, direct and gravity torque of the compiled
    solver's own summary against ``_assemble`` of the same contacts (numpy sums)."""
    point = operating_point(rpm, 35.0, 700.0, axial_load=-300.0)
    model = SteadyStateModel(config, mode=mode)  # type: ignore[arg-type]
    got = model.solve(point)
    scene = model.scene(point.temperature, point.screw_speed)
    want = assemble(
        model, point, model.resolved_mode(), scene, got.balls, got.state, got.contacts, 0, 0.0
    )
    scale = max(abs(want.output.drag_torque), 1e-300)
    assert got.output.drag_torque == pytest.approx(want.output.drag_torque, rel=1e-13, abs=0)
    np.testing.assert_allclose(got.output.nut_torque, want.output.nut_torque, atol=1e-13 * scale)
    for name in MECHANISMS:
        assert getattr(got.output.breakdown, name) == pytest.approx(
            getattr(want.output.breakdown, name), abs=1e-13 * scale
        )
    assert got.screw_torque_direct == pytest.approx(want.screw_torque_direct, rel=1e-12)
    assert got.gravity_torque == pytest.approx(want.gravity_torque, rel=1e-12, abs=1e-300)
    assert got.output.notes == want.output.notes
    assert got.output.contacts is not None and want.output.contacts is not None
    for name in ContactStates.__dataclass_fields__:
        np.testing.assert_allclose(
            getattr(got.output.contacts, name),
            getattr(want.output.contacts, name),
            rtol=1e-14,
            atol=0,
            err_msg=name,
        )


def test_predicted_start_lies_on_the_last_two_solutions(config: TwinConfig) -> None:
    """The warm start extrapolated from two solutions: their own points give them back, a
    point beyond the second lies on the line through both (offsets, rates over the speed)."""
    first, second = operating_point(200.0, 20.0, 1000.0), operating_point(220.0, 22.0, 1100.0)
    model = SteadyStateModel(config, mode="symmetric")
    a = model.solve(first).state
    b = model.solve(second).state
    back = predicted_start(model, first, 2)
    assert back is not None
    np.testing.assert_allclose(back.ball_nb, a.ball_nb, rtol=1e-12, atol=1e-20)
    np.testing.assert_allclose(back.kinematics, a.kinematics, rtol=1e-12)
    beyond = predicted_start(model, operating_point(230.0, 23.0, 1150.0), 2)
    assert beyond is not None
    np.testing.assert_allclose(
        beyond.nut_offset, b.nut_offset + 0.5 * (b.nut_offset - a.nut_offset), rtol=1e-12
    )
    per_speed = b.kinematics / second.screw_speed
    expected = per_speed + 0.5 * (per_speed - a.kinematics / first.screw_speed)
    np.testing.assert_allclose(beyond.kinematics, expected * 230.0 * RPM, rtol=1e-12)
    assert predicted_start(model, operating_point(-220.0, 22.0, 1100.0), 2) is None  # reversed


def test_kept_kernel_inputs_are_those_of_their_scene_and_loads(config: TwinConfig) -> None:
    """The residual scales and scene parameters kept per scene and loads object: those of
    residual_scales and scene_arrays; equal loads in another array are another entry, and a
    warm solve with kept inputs is the solve with fresh ones, to the last bit."""
    point = operating_point(150.0, 30.0, 900.0)
    model = SteadyStateModel(config, mode="symmetric")
    model.solve(point)
    scene = model.scene(point.temperature, point.screw_speed)
    loads = model._loads[(point.preload, point.axial_load)]
    kept = kernel_inputs(model, scene, loads)
    force, moment = residual_scales(config, scene, loads)
    assert kept.scales == (force, moment, force * config.screw.balls_per_nut)
    assert np.array_equal(kept.parameters, np.array(scene_arrays(scene), dtype=np.float64))
    assert kernel_inputs(model, scene, loads) is kept
    copy = loads.copy()
    other = kernel_inputs(model, scene, copy)
    assert other is not kept and other.loads is copy and other.scales == kept.scales
    again = model.solve(point)  # from its own solution, with the kept inputs
    fresh = SteadyStateModel(config, mode="symmetric")
    fresh.solve(point)
    fresh._kernel_inputs.clear()
    expected = fresh.solve(point)
    assert again.output.drag_torque == expected.output.drag_torque
    assert np.array_equal(again.state.kinematics, expected.state.kinematics)


def test_the_compiled_extrapolation_is_the_readable_line(config: TwinConfig) -> None:
    """``steady_solver.extrapolate`` (the warm-start predictor) against ``steady.along_line``
    (the start-up path's secant) on two full-mode solutions, beyond, between and before."""
    model = SteadyStateModel(config, mode="full")
    a = model.solve(operating_point(200.0, 20.0, 1000.0)).state
    b = model.solve(operating_point(220.0, 22.0, 1100.0)).state
    count = a.ball_nb.shape[0]
    for fraction in (-1.0, 0.3, 2.0):
        speed = 240.0 * RPM
        readable = steady.along_line(a, b, fraction, speed)
        start = SteadyState(np.empty((count, 2)), np.empty((count, 4)), np.empty(2), speed)
        steady_solver.extrapolate(
            (a.ball_nb, a.kinematics, a.nut_offset, a.screw_speed),
            (b.ball_nb, b.kinematics, b.nut_offset, b.screw_speed),
            fraction,
            speed,
            start.ball_nb,
            start.kinematics,
            start.nut_offset,
        )
        np.testing.assert_allclose(start.ball_nb, readable.ball_nb, rtol=1e-14, atol=1e-22)
        np.testing.assert_allclose(start.kinematics, readable.kinematics, rtol=1e-14, atol=1e-12)
        np.testing.assert_allclose(start.nut_offset, readable.nut_offset, rtol=1e-14, atol=1e-22)


def test_a_point_solved_again_starts_from_its_own_polished_solution(config: TwinConfig) -> None:
    """A point among the last two solved starts from its own solution; when a warm solve
    polished it, no step is taken: the same state and the same outputs, to the last bit."""
    first, second = operating_point(200.0, 20.0, 1000.0), operating_point(220.0, 22.0, 1100.0)
    model = SteadyStateModel(config, mode="full")
    model.solve(first)  # cold: not polished
    polished = model.solve(second)
    assert polished.state.polished
    model.solve(first)
    again = model.solve(second)
    assert again.iterations == 0
    np.testing.assert_array_equal(again.state.ball_nb, polished.state.ball_nb)
    np.testing.assert_array_equal(again.state.kinematics, polished.state.kinematics)
    assert again.output.drag_torque == polished.output.drag_torque
    assert again.output.contacts is not None and polished.output.contacts is not None
    np.testing.assert_array_equal(
        again.output.contacts.normal_force, polished.output.contacts.normal_force
    )


def test_full_cold_solve_of_a_horizontal_screw_equals_the_reference(config: TwinConfig) -> None:
    """On a horizontal screw gravity differs from sphere to sphere: the cold solve starts from
    the averaged two-sphere problem and must still reach the solution of the readable Newton
    solving every sphere directly."""
    horizontal = replace(config, screw=replace(config.screw, orientation="horizontal"))
    point = operating_point(300.0, 20.0, 800.0, axial_load=200.0)
    model = SteadyStateModel(horizontal, mode="full")
    got = model.solve(point)
    assert "averaged 50" in model._ball_sets  # the averaged start was taken
    spread = got.state.ball_nb[got.balls.nut == 0, 1]
    assert np.ptp(spread) > 1e-5 * np.max(np.abs(spread))  # the spheres differ (gravity)
    reference = SteadyStateModel(horizontal, mode="full", backend="newton").solve(point)
    assert_same_solution(got, reference)


# ----------------------------------------------------------------------------- failures
@pytest.mark.parametrize("backend", ["compiled", "reference"])
def test_unreachable_tolerance_raises_a_clear_error(config: TwinConfig, backend: str) -> None:
    model = SteadyStateModel(config, mode="symmetric", tolerance=1e-300, backend=backend)  # type: ignore[arg-type]
    prefix = f"steady state did not converge in {solver_settings.NEWTON_MAX_ITER} iterations"
    with pytest.raises(SolverError, match=prefix):
        model.solve(operating_point(100.0, 20.0, 1500.0))


def test_absurd_start_gives_up_with_a_solver_error(config: TwinConfig) -> None:
    point = operating_point(100.0, 20.0, 1500.0)
    model = SteadyStateModel(config, mode="symmetric")
    balls = model.ball_set("symmetric")
    loads = model.nut_axial_loads(point)
    scene = model.scene(point.temperature, point.screw_speed)
    start = initial_state(config, scene, balls, loads)
    absurd = SteadyState(
        np.full_like(start.ball_nb, 1e-3), start.kinematics, 3.0 * start.nut_offset, 1.0
    )
    with pytest.raises(SolverError, match="steady state"):
        model._newton(scene, balls, absurd, loads)
