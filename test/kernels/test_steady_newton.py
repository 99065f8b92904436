"""The compiled steady-state Newton iteration equals the reference ``SteadyStateModel._newton``.

Oracle: the reference ``_newton`` itself (with the default compiled contact laws, so that both
iterations see the same residual function). From the same start both converge to the same state
(relative 1e-7 of each array's scale) and, through ``solve()`` with ``_newton`` monkeypatched on
one instance only, to the same drag torque (relative 1e-8). Where the reference does not
converge, neither does the compiled iteration (both raise SolverError).

Points: the paper's screw at 20 C / 100 rpm / 1500 N, -20 C / 1000 rpm / 500 N,
60 C / 4000 rpm / 3000 N, zero speed and zero preload, in symmetric and full mode.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.typing import NDArray

from ballscrew_twin.errors import SolverError
from ballscrew_twin.kernels import steady_newton
from ballscrew_twin.kernels.steady_newton import (
    DEPENDENCY_STAMP,
    compiled_stamp,
    ensure_fresh_cache,
    frozen_constants,
    lu_solve_pair,
    newton_compiled,
)
from ballscrew_twin.models import steady
from ballscrew_twin.models.base import OperatingPoint
from ballscrew_twin.models.contact_forces import make_scene
from ballscrew_twin.models.steady import SteadySolution, SteadyState, SteadyStateModel
from ballscrew_twin.params import TwinConfig, load_config

FloatArray = NDArray[np.float64]
RPM = 2.0 * math.pi / 60.0
DRAG_RTOL = 1e-8
STATE_RTOL = 1e-7

# (rpm, Celsius, preload N)
POINTS = {
    "20C-100rpm-1500N": (100.0, 20.0, 1500.0),
    "-20C-1000rpm-500N": (1000.0, -20.0, 500.0),
    "60C-4000rpm-3000N": (4000.0, 60.0, 3000.0),
    "20C-0rpm-1500N": (0.0, 20.0, 1500.0),
    "20C-100rpm-0N": (100.0, 20.0, 0.0),
}
MODES = ("symmetric", "full")


def operating_point(rpm: float, celsius: float, preload: float) -> OperatingPoint:
    return OperatingPoint(screw_speed=rpm * RPM, temperature=celsius + 273.15, preload=preload)


def nearby(point: OperatingPoint) -> OperatingPoint:
    """A neighbouring point for a warm-started solve."""
    return OperatingPoint(
        screw_speed=point.screw_speed * 1.1,
        temperature=point.temperature + 1.0,
        preload=point.preload + 20.0,
    )


def assert_states_equal(got: SteadyState, ref: SteadyState) -> None:
    """Equal to STATE_RTOL relative, entries near zero against the array's own scale."""
    for name in ("ball_nb", "kinematics", "nut_offset"):
        expected = getattr(ref, name)
        scale = float(np.max(np.abs(expected), initial=0.0))
        np.testing.assert_allclose(
            getattr(got, name), expected, rtol=STATE_RTOL, atol=STATE_RTOL * scale, err_msg=name
        )
    assert got.screw_speed == ref.screw_speed


def assert_solutions_equal(got: SteadySolution, ref: SteadySolution) -> None:
    assert got.output.drag_torque == pytest.approx(ref.output.drag_torque, rel=DRAG_RTOL, abs=0)
    np.testing.assert_allclose(got.output.nut_torque, ref.output.nut_torque, rtol=DRAG_RTOL)
    assert_states_equal(got.state, ref.state)
    assert got.residual < 1e-10


@pytest.fixture(scope="module")
def config() -> TwinConfig:
    return load_config()


# ----------------------------------------------------------------------------- compiled constants
def test_frozen_constants_are_those_of_the_reference() -> None:
    """The constants numba froze into the cached code are the current ones of steady.py."""
    ensure_fresh_cache()
    assert frozen_constants() == (
        steady.NEWTON_MAX_ITER,
        steady.LINE_SEARCH_STEPS,
        steady.MIN_STEP,
        steady.DIAGONAL_SHIFT,
        steady.POSITION_STEP,
        steady.KINEMATIC_STEP_REL,
    )
    assert steady_newton.NEWTON_MAX_ITER == steady.NEWTON_MAX_ITER


def test_cached_code_is_built_from_the_current_contact_kernel() -> None:
    ensure_fresh_cache()
    assert compiled_stamp() == DEPENDENCY_STAMP
    assert ensure_fresh_cache() is False  # checked once per process


# ----------------------------------------------------------------------------- linear algebra
def test_lu_solve_pair_equals_numpy_and_flags_singular_blocks() -> None:
    rng = np.random.default_rng(7)
    for _ in range(20):
        a = rng.normal(size=(6, 6)) * 10.0 ** rng.integers(-6, 7, size=6)[:, None]
        r1, r2 = rng.normal(size=6), rng.normal(size=6)
        x1, x2 = np.empty(6), np.empty(6)
        assert lu_solve_pair(a.copy(), r1, r2, x1, x2)
        np.testing.assert_allclose(x1, np.linalg.solve(a, r1), rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(x2, np.linalg.solve(a, r2), rtol=1e-9, atol=1e-12)
    singular = rng.normal(size=(6, 6))
    singular[:, 3] = 0.0
    with pytest.raises(np.linalg.LinAlgError):
        np.linalg.solve(singular, np.ones(6))
    assert not lu_solve_pair(singular.copy(), np.ones(6), np.ones(6), np.empty(6), np.empty(6))


# ----------------------------------------------------------------------------- Newton alone
@pytest.mark.parametrize("mode", MODES)
@pytest.mark.parametrize("point_name", list(POINTS))
def test_newton_from_the_same_start_reaches_the_same_state(
    config: TwinConfig, mode: str, point_name: str
) -> None:
    """Static stage from the Hertz estimate, then the speed from a perturbed solution."""
    point = operating_point(*POINTS[point_name])
    model = SteadyStateModel(config, mode=mode)  # type: ignore[arg-type]
    balls = model.ball_set(model.resolved_mode())
    loads = model.nut_axial_loads(point)
    static = make_scene(config, point.temperature, 0.0)
    start = model._initial_state(static, balls, loads)
    ref = model._newton(static, balls, start, loads)
    got = newton_compiled(model, static, balls, start, loads)
    assert_states_equal(got[0], ref[0])
    assert got[3] < model.tolerance
    assert abs(got[2] - ref[2]) <= 1
    np.testing.assert_allclose(got[1].force, ref[1].force, atol=1e-9 * np.abs(loads).max())

    scene = make_scene(config, point.temperature, point.screw_speed)
    solved = model.solve(point).state
    rng = np.random.default_rng(11)
    count = len(balls.nut)
    perturbed = SteadyState(
        solved.ball_nb + rng.normal(scale=2e-9, size=(count, 2)),
        solved.kinematics * (1.0 + rng.normal(scale=1e-4, size=(count, 4))),
        solved.nut_offset + rng.normal(scale=2e-9, size=2),
        solved.screw_speed,
    )
    try:
        ref = model._newton(scene, balls, perturbed, loads)
    except SolverError:  # then the compiled iteration must give up too
        with pytest.raises(SolverError):
            newton_compiled(model, scene, balls, perturbed, loads)
        return
    got = newton_compiled(model, scene, balls, perturbed, loads)
    assert_states_equal(got[0], ref[0])
    assert_states_equal(got[0], solved)
    assert got[3] < model.tolerance
    assert got[1].active.tolist() == ref[1].active.tolist()


# ----------------------------------------------------------------------------- through solve()
@pytest.mark.parametrize("mode", MODES)
@pytest.mark.parametrize("point_name", list(POINTS))
def test_solve_with_the_compiled_newton_is_unchanged(
    config: TwinConfig, mode: str, point_name: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Cold solve (static stage, speed, continuation) and a warm-started solve nearby."""
    point = operating_point(*POINTS[point_name])
    reference = SteadyStateModel(config, mode=mode)  # type: ignore[arg-type]
    compiled = SteadyStateModel(config, mode=mode)  # type: ignore[arg-type]
    monkeypatch.setattr(
        compiled,
        "_newton",
        lambda scene, balls, state, loads: newton_compiled(compiled, scene, balls, state, loads),
    )
    for target in (point, nearby(point)):
        ref = reference.solve(target)
        got = compiled.solve(target)
        assert_solutions_equal(got, ref)
        assert abs(got.iterations - ref.iterations) <= 2
    assert SteadyStateModel._newton is steady.SteadyStateModel._newton  # class untouched


# ----------------------------------------------------------------------------- failures
@pytest.mark.parametrize("mode", MODES)
def test_non_convergence_raises_in_both(config: TwinConfig, mode: str) -> None:
    """An unreachable tolerance: both run NEWTON_MAX_ITER iterations and raise alike."""
    point = operating_point(100.0, 20.0, 1500.0)
    model = SteadyStateModel(config, mode=mode, tolerance=1e-300)  # type: ignore[arg-type]
    balls = model.ball_set(model.resolved_mode())
    loads = model.nut_axial_loads(point)
    scene = make_scene(config, point.temperature, point.screw_speed)
    start = model._initial_state(scene, balls, loads)
    prefix = f"steady state did not converge in {steady.NEWTON_MAX_ITER} iterations"
    with pytest.raises(SolverError, match=prefix):
        model._newton(scene, balls, start, loads)
    with pytest.raises(SolverError, match=prefix):
        newton_compiled(model, scene, balls, start, loads)


def test_absurd_start_raises_in_both(config: TwinConfig) -> None:
    """Spheres far outside their grooves: both give up (the failure path itself is chaotic:
    which of 'did not converge' or 'singular' comes first depends on rounding)."""
    point = operating_point(100.0, 20.0, 1500.0)
    model = SteadyStateModel(config, mode="symmetric")
    balls = model.ball_set("symmetric")
    loads = model.nut_axial_loads(point)
    scene = make_scene(config, point.temperature, point.screw_speed)
    start = model._initial_state(scene, balls, loads)
    absurd = SteadyState(
        np.full_like(start.ball_nb, 1e-3),
        start.kinematics,
        3.0 * start.nut_offset,
        start.screw_speed,
    )
    with pytest.raises(SolverError, match="steady state"):
        model._newton(scene, balls, absurd, loads)
    with pytest.raises(SolverError, match="steady state"):
        newton_compiled(model, scene, balls, absurd, loads)


def test_benchmark_reports_both() -> None:
    text = steady_newton.benchmark(repeat=2)
    assert "symmetric" in text and "full" in text and "compiled Newton" in text
