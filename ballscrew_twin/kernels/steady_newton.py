"""Compiled steady-state Newton iteration (numba): the twin of ``SteadyStateModel._newton``.

:func:`newton_kernel` performs the reference iteration of
:meth:`ballscrew_twin.models.steady.SteadyStateModel._newton` step for step, with the contact laws
evaluated by :func:`ballscrew_twin.kernels.contacts.contacts_kernel` and no Python in the loop:

- residual rows per sphere (F_n, F_b, F_t) / force scale and (M_t, M_n, M_b) / moment scale, and
  per nut the axial push of its spheres less the load, over the nut scale (``_residual``,
  ``_scales``);
- mask: the four rates are frozen (identity rows and columns) at zero screw speed
  (``_unknown_mask``);
- central-difference Jacobian with steps POSITION_STEP [m] for (n, b) and the nut offsets and
  KINEMATIC_STEP_REL max(|screw speed|, 1 rad/s) [rad/s] for the rates, one contact evaluation
  of every sphere per column (spheres are independent given their nut's offset);
- bordered step: sphere blocks shifted by DIAGONAL_SHIFT |diag|, eliminated per nut (Schur
  complement, ``_damped_step``); the 6 x 6 blocks are solved by LU with partial pivoting and an
  exactly zero pivot is reported as singular, as LAPACK's ``gesv`` behind ``np.linalg.solve``;
- backtracking line search on the squared masked residual, LINE_SEARCH_STEPS halvings, a step
  shorter than MIN_STEP accepted without decrease (only the sphere rows must be finite), and
  the reference's bookkeeping kept as it is, including its behaviour when every trial fails;
- at most NEWTON_MAX_ITER iterations; converged when the worst masked scaled residual is below
  the tolerance (Python's ``max`` of the two maxima, NaN propagation included).

Results agree with the reference to rounding (different summation order in a few sums and a
different LU than LAPACK's), i.e. the converged states to far below the solver tolerance
(test/kernels/test_steady_newton.py).

The solver constants are imported from :mod:`ballscrew_twin.models.steady`; numba freezes them
into the cached machine code and the cache is invalidated only by a change of *this* file, so a
test (``test_frozen_constants_are_those_of_the_reference``) reads them back from compiled code.
The same holds for ``contacts_kernel``, whose machine code is linked into the cached Newton
kernel: numba does not notice a change of kernels/contacts.py either. :data:`DEPENDENCY_STAMP`
(a hash of contacts.py and of the constants) is therefore frozen into the cache as well, and
:func:`ensure_fresh_cache` (called by :func:`newton_compiled`) recompiles this module's kernels
once when the cached stamp is not the current one.

:func:`newton_compiled` is the drop-in for ``SteadyStateModel._newton``: import it lazily inside
the model (this module imports ``models.steady`` at import time) and call
``newton_compiled(self, scene, balls, state, loads)``.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

from ..errors import SolverError
from ..models.contact_forces import ContactEvaluation, ContactScene
from ..models.steady import (
    DIAGONAL_SHIFT,
    KINEMATIC_STEP_REL,
    LINE_SEARCH_STEPS,
    MIN_STEP,
    NEWTON_MAX_ITER,
    POSITION_STEP,
    BallSet,
    SteadyState,
    SteadyStateModel,
)
from ..timing import median_time
from . import contacts as _contacts_module
from .cache_stamp import dependency_stamp
from .contacts import R_FORCE, R_GROOVE_FORCE, R_MOMENT, contacts_kernel, evaluate_contacts_compiled
from .contacts import scene_arrays as scene_arrays

FloatArray = NDArray[np.float64]

#: status codes of :func:`newton_kernel`
STATUS_CONVERGED = 0
STATUS_NOT_CONVERGED = 1
STATUS_SINGULAR = 2  # an exactly singular sphere block (the reference raises from np.linalg)

# Positions in the tuple of scene_arrays(scene) (the scalar parameters of contacts_kernel).
_I_BALL_RADIUS = 0
_I_SIN_HELIX = 4
_I_COS_HELIX = 5
_I_SCREW_SPEED = 12
_I_BALL_MASS = 16


SOLVER_CONSTANTS = (
    NEWTON_MAX_ITER,
    LINE_SEARCH_STEPS,
    MIN_STEP,
    DIAGONAL_SHIFT,
    POSITION_STEP,
    KINEMATIC_STEP_REL,
)


#: frozen into the cached code by :func:`compiled_stamp`; compared at first use
DEPENDENCY_STAMP = dependency_stamp((_contacts_module,), SOLVER_CONSTANTS)


@njit(cache=True)
def compiled_stamp():
    """DEPENDENCY_STAMP as it was when the cached machine code was compiled."""
    return DEPENDENCY_STAMP


@njit(cache=True)
def frozen_constants():
    """The solver constants as the cached machine code sees them (tested against steady.py).

    Returns:
        (NEWTON_MAX_ITER, LINE_SEARCH_STEPS, MIN_STEP [-], DIAGONAL_SHIFT [-],
        POSITION_STEP [m], KINEMATIC_STEP_REL [-]).
    """
    return SOLVER_CONSTANTS


# ----------------------------------------------------------------------------- small helpers
@njit(cache=True, error_model="numpy")
def _abs_max(x):
    """np.max(np.abs(x)) of a non-empty array, NaN if any entry is NaN (numpy's rule)."""
    flat = x.ravel()
    worst = abs(flat[0])
    for k in range(flat.size):
        value = abs(flat[k])
        if math.isnan(value):
            return value
        if value > worst:
            worst = value
    return worst


@njit(cache=True, error_model="numpy")
def _worst(ball_res, nut_res, frozen_rates):
    """max(max |masked ball residual|, max |nut residual|) with Python's ``max`` semantics
    (the first argument is kept unless the second is larger, so NaN propagates only from it)."""
    count = ball_res.shape[0]
    first = 0.0
    for i in range(count):
        for r in range(6):
            value = 0.0 if (frozen_rates and r >= 2) else abs(ball_res[i, r])
            if math.isnan(value):
                first = value
                break
            if value > first:
                first = value
        if math.isnan(first):
            break
    second = _abs_max(nut_res)
    return second if second > first else first


@njit(cache=True, error_model="numpy")
def _merit(ball_res, nut_res, frozen_rates):
    """Squared masked residual: sum(where(mask, ball_res, 0)^2) + sum(nut_res^2) [-]."""
    total = 0.0
    for i in range(ball_res.shape[0]):
        for r in range(6):
            if not (frozen_rates and r >= 2):
                total += ball_res[i, r] * ball_res[i, r]
    nut_total = 0.0
    for k in range(nut_res.shape[0]):
        nut_total += nut_res[k] * nut_res[k]
    return total + nut_total


@njit(cache=True, error_model="numpy")
def lu_solve_pair(a, rhs_a, rhs_b, out_a, out_b):
    """Solve a x = rhs_a and a x = rhs_b for one n x n matrix (LU, partial pivoting).

    ``a`` is overwritten by its factors. The pivot is the first entry of largest magnitude in
    its column (LAPACK's idamax); an exactly zero pivot means singular, as for ``gesv``.

    Returns:
        True when solved, False when ``a`` is exactly singular (outputs then undefined).
    """
    n = a.shape[0]
    perm = np.arange(n)
    singular = False
    for k in range(n):
        pivot = k
        best = abs(a[k, k])
        for r in range(k + 1, n):
            value = abs(a[r, k])
            if value > best:
                best = value
                pivot = r
        if pivot != k:
            for c in range(n):
                tmp = a[k, c]
                a[k, c] = a[pivot, c]
                a[pivot, c] = tmp
            tmp_i = perm[k]
            perm[k] = perm[pivot]
            perm[pivot] = tmp_i
        if a[k, k] == 0.0:
            singular = True
            continue
        inv = 1.0 / a[k, k]
        for r in range(k + 1, n):
            a[r, k] *= inv
            factor = a[r, k]
            if factor != 0.0:
                for c in range(k + 1, n):
                    a[r, c] -= factor * a[k, c]
    if singular:
        return False
    for r in range(n):
        out_a[r] = rhs_a[perm[r]]
        out_b[r] = rhs_b[perm[r]]
    for r in range(n):  # forward substitution, unit lower factor
        sa = out_a[r]
        sb = out_b[r]
        for c in range(r):
            sa -= a[r, c] * out_a[c]
            sb -= a[r, c] * out_b[c]
        out_a[r] = sa
        out_b[r] = sb
    for r in range(n - 1, -1, -1):  # back substitution
        sa = out_a[r]
        sb = out_b[r]
        for c in range(r + 1, n):
            sa -= a[r, c] * out_a[c]
            sb -= a[r, c] * out_b[c]
        out_a[r] = sa / a[r, r]
        out_b[r] = sb / a[r, r]
    return True


# ----------------------------------------------------------------------------- residual
@njit(cache=True, error_model="numpy")
def _residual(z, e_nut, nut, weight, gravity, loads, force_scale, moment_scale, nut_scale, scene):
    """Scaled residuals of packed state z (B, 6) = (n, b [m], w_B, omega_t,n,b [rad/s]) and nut
    offsets e_nut (2,) [m], as ``SteadyStateModel._residual``.

    Returns:
        ball_res (B, 6) rows (F_n, F_b, F_t) / force scale, (M_t, M_n, M_b) / moment scale;
        axial (B,) each sphere's axial push on its nut times its weight over the nut scale;
        nut_res (2,) sum of axial per nut minus load / nut scale.
    """
    count = z.shape[0]
    ball_nb = np.empty((count, 2))
    kinematics = np.empty((count, 4))
    e_ball = np.empty(count)
    for i in range(count):
        ball_nb[i, 0] = z[i, 0]
        ball_nb[i, 1] = z[i, 1]
        for k in range(4):
            kinematics[i, k] = z[i, 2 + k]
        e_ball[i] = e_nut[nut[i]]
    # Steady state: centre velocity from the helical motion (no given velocity), no nut slide.
    no_velocity = np.zeros((0, 3))
    no_slide = np.zeros(count)
    _, out = contacts_kernel(
        ball_nb,
        kinematics,
        e_ball,
        gravity,
        no_velocity,
        no_slide,
        np.zeros((0, 4)),
        False,
        *scene,
    )
    sin_helix = scene[_I_SIN_HELIX]
    cos_helix = scene[_I_COS_HELIX]
    ball_res = np.empty((count, 6))
    axial = np.empty(count)
    nut_sum = np.zeros(2)
    for i in range(count):
        ball_res[i, 0] = out[R_FORCE + 1, i, 0] / force_scale
        ball_res[i, 1] = out[R_FORCE + 2, i, 0] / force_scale
        ball_res[i, 2] = out[R_FORCE + 0, i, 0] / force_scale
        for k in range(3):
            ball_res[i, 3 + k] = out[R_MOMENT + k, i, 0] / moment_scale
        # Force of the sphere on its nut's half grooves N1, N2 (the screw's S1, S2 excluded).
        on_t = (0.0 + 0.0 + out[R_GROOVE_FORCE, i, 2]) + out[R_GROOVE_FORCE, i, 3]
        on_n = (0.0 + 0.0 + out[R_GROOVE_FORCE + 1, i, 2]) + out[R_GROOVE_FORCE + 1, i, 3]
        on_b = (0.0 + 0.0 + out[R_GROOVE_FORCE + 2, i, 2]) + out[R_GROOVE_FORCE + 2, i, 3]
        push = on_t * sin_helix + on_n * 0.0 + on_b * cos_helix
        axial[i] = push * weight[i] / nut_scale
        nut_sum[nut[i]] += axial[i]
    nut_res = np.empty(2)
    for k in range(2):
        nut_res[k] = nut_sum[k] - loads[k] / nut_scale
    return ball_res, axial, nut_res


# ----------------------------------------------------------------------------- Newton
@njit(cache=True, error_model="numpy")
def newton_kernel(
    ball_nb, kinematics, nut_offset, nut, weight, gravity, loads, balls_per_nut, tolerance, scene
):
    """Damped Newton iteration of the steady state, exactly ``SteadyStateModel._newton``.

    Args:
        ball_nb: (B, 2) initial ball-centre offsets (n, b) [m].
        kinematics: (B, 4) initial orbital rate and ball angular velocity (t, n, b) [rad/s].
        nut_offset: (2,) initial axial groove offsets of master and slave nut [m].
        nut: (B,) int64 nut of each sphere (0 master, 1 slave).
        weight: (B,) physical spheres each solved sphere stands for [-].
        gravity: (B, 3) gravitational acceleration in Frenet components [m/s^2].
        loads: (2,) force the spheres must exert on each nut along +z [N].
        balls_per_nut: loaded spheres per nut Z [-] (float).
        tolerance: convergence limit of the worst scaled residual [-].
        scene: ``scene_arrays(scene)``, the scalar parameters of ``contacts_kernel``.

    Returns:
        (ball_nb (B, 2) [m], kinematics (B, 4) [rad/s], nut_offset (2,) [m], iterations,
        worst scaled residual [-], status): status 0 converged, 1 not converged in
        NEWTON_MAX_ITER iterations, 2 singular sphere block; the state is the last iterate.
    """
    count = ball_nb.shape[0]
    screw_speed = scene[_I_SCREW_SPEED]
    frozen_rates = screw_speed == 0.0
    free_columns = 2 if frozen_rates else 6
    # _scales: force scale [N], moment scale [N m], nut scale [N].
    per_ball = max(abs(loads[0]), abs(loads[1])) / balls_per_nut
    force_scale = max(per_ball, scene[_I_BALL_MASS] * 9.81, 1e-6)
    moment_scale = force_scale * scene[_I_BALL_RADIUS]
    nut_scale = force_scale * balls_per_nut
    speed_scale = max(abs(screw_speed), 1.0)
    steps = np.empty(6)
    steps[0] = POSITION_STEP
    steps[1] = POSITION_STEP
    for j in range(2, 6):
        steps[j] = KINEMATIC_STEP_REL * speed_scale

    z = np.empty((count, 6))
    for i in range(count):
        z[i, 0] = ball_nb[i, 0]
        z[i, 1] = ball_nb[i, 1]
        for k in range(4):
            z[i, 2 + k] = kinematics[i, k]
    e = nut_offset.copy()
    args = (nut, weight, gravity, loads, force_scale, moment_scale, nut_scale, scene)
    ball_res, _, nut_res = _residual(z, e, *args)

    jac = np.zeros((count, 6, 6))
    jac_nut_z = np.zeros((count, 6))
    jac_z_e = np.zeros((count, 6))
    block = np.empty((6, 6))
    rhs_e = np.empty(6)
    rhs_r = np.empty(6)
    inv_r = np.empty((count, 6))
    inv_e = np.empty((count, 6))
    sol_r = np.empty(6)
    sol_e = np.empty(6)
    dz = np.empty((count, 6))
    de = np.zeros(2)
    trial_z = np.empty((count, 6))
    trial_e = np.empty(2)

    for iteration in range(1, NEWTON_MAX_ITER + 1):
        worst = _worst(ball_res, nut_res, frozen_rates)
        if worst < tolerance:
            return z[:, :2].copy(), z[:, 2:].copy(), e, iteration - 1, worst, STATUS_CONVERGED
        # Central-difference Jacobian, one column of every sphere per pair of evaluations. The
        # columns of frozen rates are skipped: the reference overwrites them with identity.
        jac[:] = 0.0
        jac_nut_z[:] = 0.0
        for j in range(free_columns):
            zp = z.copy()
            zm = z.copy()
            for i in range(count):
                zp[i, j] += steps[j]
                zm[i, j] -= steps[j]
            rb_p, ax_p, _ = _residual(zp, e, *args)
            rb_m, ax_m, _ = _residual(zm, e, *args)
            for i in range(count):
                for r in range(6):
                    jac[i, r, j] = (rb_p[i, r] - rb_m[i, r]) / (2.0 * steps[j])
                jac_nut_z[i, j] = (ax_p[i] - ax_m[i]) / (2.0 * steps[j])
        e_p = e + POSITION_STEP
        e_m = e - POSITION_STEP
        rb_p, _, rn_p = _residual(z, e_p, *args)
        rb_m, _, rn_m = _residual(z, e_m, *args)
        for i in range(count):
            for r in range(6):
                jac_z_e[i, r] = (rb_p[i, r] - rb_m[i, r]) / (2.0 * POSITION_STEP)
        jac_e_0 = (rn_p[0] - rn_m[0]) / (2.0 * POSITION_STEP)
        jac_e_1 = (rn_p[1] - rn_m[1]) / (2.0 * POSITION_STEP)
        if frozen_rates:  # identity rows and columns of the frozen unknowns
            for i in range(count):
                for r in range(6):
                    for c in range(6):
                        if r >= 2 or c >= 2:
                            jac[i, r, c] = 1.0 if r == c else 0.0
                for r in range(2, 6):
                    jac_z_e[i, r] = 0.0
                    jac_nut_z[i, r] = 0.0

        # _damped_step: shifted sphere blocks, eliminated per nut (Schur complement).
        for i in range(count):
            for r in range(6):
                shift = DIAGONAL_SHIFT * (abs(jac[i, r, r]) + 1e-30)
                for c in range(6):
                    block[r, c] = jac[i, r, c] + shift * (1.0 if r == c else 0.0)
                rhs_r[r] = 0.0 if (frozen_rates and r >= 2) else ball_res[i, r]
                rhs_e[r] = jac_z_e[i, r]
            if not lu_solve_pair(block, rhs_r, rhs_e, sol_r, sol_e):
                return (
                    z[:, :2].copy(),
                    z[:, 2:].copy(),
                    e,
                    iteration - 1,
                    worst,
                    STATUS_SINGULAR,
                )
            for r in range(6):
                inv_r[i, r] = sol_r[r]
                inv_e[i, r] = sol_e[r]
        schur = np.empty(2)
        schur[0] = jac_e_0 * (1.0 + DIAGONAL_SHIFT)
        schur[1] = jac_e_1 * (1.0 + DIAGONAL_SHIFT)
        coupling_e = np.zeros(2)
        coupling_r = np.zeros(2)
        for i in range(count):
            k = nut[i]
            for r in range(6):
                coupling_e[k] += jac_nut_z[i, r] * inv_e[i, r]
                coupling_r[k] += jac_nut_z[i, r] * inv_r[i, r]
        for k in range(2):
            value = schur[k] - coupling_e[k]
            rhs = -nut_res[k] + coupling_r[k]
            de[k] = rhs / value if value != 0.0 else 0.0
        for i in range(count):
            for r in range(6):
                step_ir = -(inv_r[i, r] + inv_e[i, r] * de[nut[i]])
                dz[i, r] = 0.0 if (frozen_rates and r >= 2) else step_ir

        # Backtracking line search on the squared residual; a short step is taken regardless.
        base = _merit(ball_res, nut_res, frozen_rates)
        step = 1.0
        rb = ball_res
        rn = nut_res
        for _ in range(LINE_SEARCH_STEPS):
            for i in range(count):
                for r in range(6):
                    trial_z[i, r] = z[i, r] + step * dz[i, r]
            trial_e[0] = e[0] + step * de[0]
            trial_e[1] = e[1] + step * de[1]
            rb, _, rn = _residual(trial_z, trial_e, *args)
            if np.isfinite(rb).all() and (_merit(rb, rn, frozen_rates) < base or step < MIN_STEP):
                break
            step *= 0.5
        # As the reference: when no trial is accepted, the state moves by the halved step while
        # the residual kept is that of the last trial.
        for i in range(count):
            for r in range(6):
                z[i, r] = z[i, r] + step * dz[i, r]
        e = e + step * de
        ball_res = rb
        nut_res = rn
    worst = _worst(ball_res, nut_res, frozen_rates)
    return z[:, :2].copy(), z[:, 2:].copy(), e, NEWTON_MAX_ITER, worst, STATUS_NOT_CONVERGED


# ----------------------------------------------------------------------------- Python side
_checked_cache = False


def ensure_fresh_cache() -> bool:
    """Recompile this module's kernels (dropping their numba cache) if contacts.py or the solver
    constants changed since they were cached; checked once per process.

    Returns:
        True when a stale cache was found and recompiled.
    """
    global _checked_cache
    if _checked_cache:
        return False
    stale = bool(compiled_stamp() != DEPENDENCY_STAMP)
    if stale:
        # Callees first: a caller compiled afresh links the machine code of its callees.
        for dispatcher in (
            _abs_max,
            _worst,
            _merit,
            lu_solve_pair,
            _residual,
            frozen_constants,
            newton_kernel,
            compiled_stamp,
        ):
            dispatcher.recompile()
    _checked_cache = True
    return stale


def newton_compiled(
    model: SteadyStateModel,
    scene: ContactScene,
    balls: BallSet,
    state: SteadyState,
    loads: FloatArray,
) -> tuple[SteadyState, ContactEvaluation, int, float]:
    """Drop-in for ``model._newton(scene, balls, state, loads)``, fully compiled.

    Args:
        model: the steady-state model (its tolerance [-] and ``config.screw.balls_per_nut``).
        scene: constants of the operating point (screw speed [rad/s] decides the rate mask).
        balls: the spheres solved (nut, weight [-], gravity [m/s^2] in Frenet components).
        state: initial guess (ball_nb [m], kinematics [rad/s], nut_offset [m]).
        loads: (2,) force the spheres must exert on each nut along +z [N].

    Returns:
        (converged state, its contact evaluation, Newton iterations, worst scaled residual [-]).

    Raises:
        SolverError: no convergence in NEWTON_MAX_ITER iterations, or a singular sphere block
            (same messages as the reference).
        ValueError: ``model`` drops the inertial terms, which this kernel always includes.
    """
    if not model.inertial_terms:
        raise ValueError(
            "newton_compiled keeps the centrifugal and gyroscopic terms; use the model's own "
            "Newton iteration for inertial_terms=False"
        )
    ensure_fresh_cache()
    tolerance = float(model.tolerance)
    ball_nb, kinematics, nut_offset, iterations, worst, status = newton_kernel(
        np.ascontiguousarray(state.ball_nb, dtype=np.float64),
        np.ascontiguousarray(state.kinematics, dtype=np.float64),
        np.ascontiguousarray(state.nut_offset, dtype=np.float64),
        np.ascontiguousarray(balls.nut, dtype=np.int64),
        np.ascontiguousarray(balls.weight, dtype=np.float64),
        np.ascontiguousarray(balls.gravity, dtype=np.float64),
        np.ascontiguousarray(loads, dtype=np.float64),
        float(model.config.screw.balls_per_nut),
        tolerance,
        scene_arrays(scene),
    )
    if status == STATUS_SINGULAR:
        raise SolverError("steady state: singular sphere Jacobian (Singular matrix)")
    if status != STATUS_CONVERGED:
        raise SolverError(
            f"steady state did not converge in {NEWTON_MAX_ITER} iterations "
            f"(scaled residual {worst:.3g} > {tolerance:.1g})"
        )
    solved = SteadyState(ball_nb, kinematics, nut_offset, scene.screw_speed)
    ev = evaluate_contacts_compiled(
        scene, ball_nb, kinematics, nut_offset[balls.nut], balls.gravity
    )
    return solved, ev, int(iterations), float(worst)


def use_compiled_newton(model: SteadyStateModel) -> SteadyStateModel:
    """Route ``model``'s Newton solves (this instance only) through :func:`newton_compiled`."""

    def newton(
        scene: ContactScene, balls: BallSet, state: SteadyState, loads: FloatArray
    ) -> tuple[SteadyState, ContactEvaluation, int, float]:
        return newton_compiled(model, scene, balls, state, loads)

    model._newton = newton  # type: ignore[method-assign]
    return model


# ----------------------------------------------------------------------------- benchmark
def benchmark(repeat: int = 40) -> str:
    """Median warm solve time, current vs compiled Newton, symmetric and full (printed).

    Warm solve as ``ballscrew-twin bench steady``: 20 C / 100 rpm / 1500 N and 21 C / 110 rpm /
    1550 N solved alternately, each warm-started from the other; time per solve. Also the time
    of the Newton iteration alone (``newton_kernel`` from the previous point's state).
    """
    from ..models.base import OperatingPoint
    from ..models.contact_forces import make_scene
    from ..params import load_config

    ensure_fresh_cache()
    rpm = 2.0 * math.pi / 60.0
    config = load_config()
    point = OperatingPoint(screw_speed=100 * rpm, temperature=293.15, preload=1500.0)
    nearby = OperatingPoint(screw_speed=110 * rpm, temperature=294.15, preload=1550.0)
    lines = [f"steady warm solve, median of {repeat} (20 C/100 rpm/1500 N <-> 21 C/110 rpm/1550 N)"]
    for mode in ("symmetric", "full"):
        current = SteadyStateModel(config, mode=mode)
        compiled = use_compiled_newton(SteadyStateModel(config, mode=mode))
        results = {}
        for name, model in (("current", current), ("compiled", compiled)):
            model.solve(point)
            model.solve(nearby)

            def warm(m: SteadyStateModel = model) -> None:
                m.solve(point)
                m.solve(nearby)

            results[name] = median_time(warm, repeat) / 2.0
        # The Newton iteration alone, warm-started at `nearby` from the state at `point`.
        base = compiled.solve(point)
        scene = make_scene(config, nearby.temperature, nearby.screw_speed)
        balls = base.balls
        start = compiled._rescaled(base.state, scene, balls, nearby.screw_speed)
        loads = compiled.nut_axial_loads(nearby)
        params = scene_arrays(scene)
        kernel_args = (
            np.ascontiguousarray(start.ball_nb, dtype=np.float64),
            np.ascontiguousarray(start.kinematics, dtype=np.float64),
            np.ascontiguousarray(start.nut_offset, dtype=np.float64),
            np.ascontiguousarray(balls.nut, dtype=np.int64),
            np.ascontiguousarray(balls.weight, dtype=np.float64),
            np.ascontiguousarray(balls.gravity, dtype=np.float64),
            np.ascontiguousarray(loads, dtype=np.float64),
            float(config.screw.balls_per_nut),
            compiled.tolerance,
            params,
        )
        iterations = newton_kernel(*kernel_args)[3]
        kernel_time = median_time(lambda a=kernel_args: newton_kernel(*a), repeat)  # type: ignore[misc]
        count = len(balls.nut)
        lines.append(
            f"  {mode:<9} {count:3d} spheres: current {results['current'] * 1e6:9.1f} us, "
            f"compiled Newton {results['compiled'] * 1e6:9.1f} us "
            f"(x{results['current'] / results['compiled']:.1f}); newton_kernel alone "
            f"{kernel_time * 1e6:8.1f} us ({iterations} iterations)"
        )
    return "\n".join(lines)


if __name__ == "__main__":
    print(benchmark())
