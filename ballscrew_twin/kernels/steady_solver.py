"""Compiled structured steady-state solver (numba): Newton with exact per-sphere Jacobian blocks.

The steady state couples each sphere only to the screw and to its own nut: its six unknowns
z_i = (n, b, w_B, omega_t, omega_n, omega_b) enter its own six balance rows and its nut's axial
row, and the nut's offset e_k enters the rows of its spheres. The Newton matrix is therefore
bordered block-diagonal, and :func:`newton_kernel` solves it as such, in one compiled call:

- each sphere is evaluated once per iterate with its seven unknowns (z_i, e_k) seeded as dual
  numbers (:mod:`ballscrew_twin.kernels.dual`) through the contact law of the contact kernel
  (:func:`ballscrew_twin.kernels.contacts.contact_law`, the same code): one pass gives its
  residual and its exact 7 x 7 Jacobian block (no difference step);
- the sphere blocks are eliminated (Schur complement onto the two nut offsets): per nut
  S_k = sum_i (G_i - A_i J_i^-1 C_i), de_k = (-g_k + sum_i A_i J_i^-1 r_i) / S_k,
  dz_i = -J_i^-1 (r_i + C_i de_k), with J_i = d r_i / d z_i, C_i = d r_i / d e_k, A_i and G_i
  the same of sphere i's axial push on its nut; the cost is linear in the sphere count;
- the rest is the iteration of the readable reference ``SteadyStateModel._newton``: the same
  scaled residuals, the same diagonal shift of the blocks, the same frozen rates at zero speed,
  the same backtracking line search on the squared residual and the same stopping rule.

The readable reference (``backend="reference"``: numpy contact laws, Python Newton with a
central-difference Jacobian) stays the definition; test/kernels/test_steady_solver.py checks that
the solutions agree to 1e-9 relative over the envelope. Units: SI throughout (m, rad/s, N, N m).

numba's cache sees a change of this file only; :data:`DEPENDENCY_STAMP` (a hash of contacts.py,
dual.py and the solver constants) is frozen into the cache and :func:`ensure_fresh_cache`
recompiles once when it is stale.
"""

from __future__ import annotations

import numpy as np
from numba import njit
from numpy.typing import NDArray

from ..models.contact_forces import ContactEvaluation
from ..models.steady import DIAGONAL_SHIFT, LINE_SEARCH_STEPS, MIN_STEP, NEWTON_MAX_ITER
from . import contacts as _contacts_module
from . import dual as _dual_module
from .cache_stamp import dependency_stamp
from .contacts import (
    IS_NUT,
    _add,
    _cross,
    _dot,
    _helical,
    _scale,
    _sub,
    contact_geometry,
    contact_law,
    contacts_kernel,
    evaluation_from_buffer,
    law_constants,
    scene_from_array,
)
from .dual import make_dual

FloatArray = NDArray[np.float64]

#: status codes of :func:`newton_kernel`
STATUS_CONVERGED = 0
STATUS_NOT_CONVERGED = 1
STATUS_SINGULAR = 2  # an exactly singular sphere block
STATUS_NOT_FINITE = 3  # every line-search step gave a non-finite residual

#: a step with the Jacobian blocks of an earlier iterate is kept when it cuts the squared
#: scaled residual at least by this factor (the norm by ~3); otherwise the blocks are refreshed
CHORD_DECREASE = 0.1
#: such steps continue below the tolerance down to this fraction of it, while they cut [-]
CHORD_POLISH = 1e-3

# Positions in the tuple of scene_arrays(scene) (the scalar parameters of contacts_kernel).
_I_SCREW_SPEED = 12
_I_BALL_MASS = 16
_I_BALL_INERTIA = 17

SOLVER_CONSTANTS = (
    NEWTON_MAX_ITER,
    LINE_SEARCH_STEPS,
    MIN_STEP,
    DIAGONAL_SHIFT,
    CHORD_DECREASE,
    CHORD_POLISH,
)

#: frozen into the cached code by :func:`compiled_stamp`; compared at first use
DEPENDENCY_STAMP = dependency_stamp((_contacts_module, _dual_module), SOLVER_CONSTANTS)

_UNIT = (
    (1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0),
    (0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0),
    (0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0),
    (0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0),
    (0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0),
    (0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0),
    (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0),
)


@njit(cache=True)
def compiled_stamp():
    """DEPENDENCY_STAMP as it was when the cached machine code was compiled."""
    return DEPENDENCY_STAMP


@njit(cache=True)
def frozen_constants():
    """The solver constants as the cached machine code sees them: (NEWTON_MAX_ITER,
    LINE_SEARCH_STEPS, MIN_STEP [-], DIAGONAL_SHIFT [-])."""
    return SOLVER_CONSTANTS


# ----------------------------------------------------------------------------- one sphere
@njit(inline="always")
def sphere_balance(n_i, b_i, e, w_ball, omega, gravity, constants, masses, inertial_terms):
    """Force and moment balance of one sphere and its axial push on its nut.

    Args:
        n_i, b_i: centre offset (n, b) from the ideal helix [m]; e: its nut's offset [m].
        w_ball: orbital rate along the thread [rad/s]; omega: angular velocity (t, n, b)
            relative to the screw [rad/s] (floats or dual numbers).
        gravity: (t, n, b) gravitational acceleration [m/s^2].
        constants: :func:`~ballscrew_twin.kernels.contacts.law_constants`.
        masses: (ball mass [kg], ball inertia [kg m^2]).
        inertial_terms: add the centrifugal force and the gyroscopic moment (``contacts_kernel``
            in steady use does), or leave them out (``SteadyStateModel(inertial_terms=False)``).

    Returns:
        (force (t, n, b) [N], moment [N m], both including gravity, and the force of the sphere
        on its nut along the screw axis [N]).
    """
    ball_mass, ball_inertia = masses
    pitch_radius = constants[2]
    lead_rate = constants[3]
    zhat = constants[4]
    screw_speed = constants[10]
    r_ball = (0.0, n_i - pitch_radius, b_i)
    v_centre = _helical(w_ball, zhat, lead_rate, r_ball)
    zero = 0.0 * n_i  # the number type of the state, with zero partials
    f_sum = (zero, zero, zero)
    m_sum = (zero, zero, zero)
    on_nut = (zero, zero, zero)
    for j in range(4):
        geometry = contact_geometry(j, constants, n_i, b_i, e, 0.0)
        if not geometry[4]:  # an inactive contact exerts nothing
            continue
        on_ball, moment, on_groove, _ = contact_law(
            j, constants, geometry, n_i, b_i, w_ball, omega, r_ball, v_centre, 0.0
        )
        f_sum = _add(f_sum, on_ball)
        m_sum = _add(m_sum, moment)
        if IS_NUT[j]:
            on_nut = _add(on_nut, on_groove)
    force = _add(f_sum, _scale(ball_mass, gravity))
    if not inertial_terms:
        return force, m_sum, _dot(on_nut, zhat)
    orbit_rate = screw_speed + w_ball
    r_perp = _sub(r_ball, _scale(_dot(r_ball, zhat), zhat))
    inertial = _scale(ball_mass * orbit_rate * orbit_rate, r_perp)
    omega_abs = _add(omega, _scale(screw_speed, zhat))
    gyro = _scale(orbit_rate, _cross(zhat, _scale(ball_inertia, omega_abs)))
    return _add(force, inertial), _sub(m_sum, gyro), _dot(on_nut, zhat)


@njit(inline="always")
def _seeded(value, k):
    """``value`` as a dual number with unit partial k."""
    return make_dual(value, _UNIT[k])


@njit(cache=True, error_model="numpy")
def linearise(
    z, e_nut, nut, weight, gravity, loads, scales, inertial_terms, scene, res, axial, jac
):
    """Residuals and exact sphere Jacobian blocks at (z, e_nut), one dual pass per sphere.

    Args:
        z: (B, 6) sphere unknowns (n, b [m], w_B, omega_t,n,b [rad/s]); e_nut: (2,) [m].
        nut: (B,) int64; weight: (B,) spheres represented [-]; gravity: (B, 3) [m/s^2];
        loads: (2,) [N]; scales: (force [N], moment [N m], nut [N]); inertial_terms: see
        :func:`sphere_balance`; scene: ``scene_arrays`` as a float64 array.
        res: (B, 6) out, scaled sphere residuals (F_n, F_b, F_t) / force, M / moment scale;
        axial: (B,) out, weighted axial push over the nut scale;
        jac: (B, 7, 7) out, rows (res_i, axial_i), columns (z_i, e_k): their derivatives.

    Returns:
        (2,) scaled nut residuals.
    """
    force_scale, moment_scale, nut_scale = scales
    constants = law_constants(*scene_from_array(scene))
    masses = (scene[_I_BALL_MASS], scene[_I_BALL_INERTIA])
    nut_sum = np.zeros(2)
    for i in range(z.shape[0]):
        k = nut[i]
        omega = (_seeded(z[i, 3], 3), _seeded(z[i, 4], 4), _seeded(z[i, 5], 5))
        force, moment, push = sphere_balance(
            _seeded(z[i, 0], 0),
            _seeded(z[i, 1], 1),
            _seeded(e_nut[k], 6),
            _seeded(z[i, 2], 2),
            omega,
            (gravity[i, 0], gravity[i, 1], gravity[i, 2]),
            constants,
            masses,
            inertial_terms,
        )
        rows = (force[1], force[2], force[0], moment[0], moment[1], moment[2])
        for r in range(6):
            scale = force_scale if r < 3 else moment_scale
            res[i, r] = rows[r].v / scale
            for c in range(7):
                jac[i, r, c] = rows[r].g[c] / scale
        share = weight[i] / nut_scale
        axial[i] = push.v * share
        for c in range(7):
            jac[i, 6, c] = push.g[c] * share
        nut_sum[k] += axial[i]
    nut_res = np.empty(2)
    for k in range(2):
        nut_res[k] = nut_sum[k] - loads[k] / nut_scale
    return nut_res


@njit(cache=True, error_model="numpy")
def residuals(z, e_nut, nut, weight, gravity, loads, scales, inertial_terms, scene, res):
    """Scaled sphere residuals into ``res`` (B, 6) and the (2,) nut residuals returned, as
    :func:`linearise` without the partials."""
    force_scale, moment_scale, nut_scale = scales
    constants = law_constants(*scene_from_array(scene))
    nut_sum = np.zeros(2)
    for i in range(z.shape[0]):
        k = nut[i]
        force, moment, push = sphere_balance(
            z[i, 0],
            z[i, 1],
            e_nut[k],
            z[i, 2],
            (z[i, 3], z[i, 4], z[i, 5]),
            (gravity[i, 0], gravity[i, 1], gravity[i, 2]),
            constants,
            (scene[_I_BALL_MASS], scene[_I_BALL_INERTIA]),
            inertial_terms,
        )
        rows = (force[1], force[2], force[0], moment[0], moment[1], moment[2])
        for r in range(6):
            res[i, r] = rows[r] / (force_scale if r < 3 else moment_scale)
        nut_sum[k] += push * (weight[i] / nut_scale)  # as linearise, operation for operation
    nut_res = np.empty(2)
    for k in range(2):
        nut_res[k] = nut_sum[k] - loads[k] / nut_scale
    return nut_res


# ----------------------------------------------------------------------------- small helpers
@njit(cache=True, error_model="numpy")
def _worst(res, nut_res, free):
    """max(max |res[:, :free]|, max |nut_res|), NaN if any of them is NaN [-]."""
    worst = 0.0
    for i in range(res.shape[0]):
        for r in range(free):
            value = abs(res[i, r])
            if not value <= worst:  # larger, or NaN
                worst = value
    for k in range(2):
        value = abs(nut_res[k])
        if not value <= worst:
            worst = value
    return worst


@njit(cache=True, error_model="numpy")
def _merit(res, nut_res, free):
    """Squared residual over the free unknowns: sum res[:, :free]^2 + sum nut_res^2 [-]."""
    total = 0.0
    for i in range(res.shape[0]):
        for r in range(free):
            total += res[i, r] * res[i, r]
    return total + nut_res[0] * nut_res[0] + nut_res[1] * nut_res[1]


@njit(cache=True, error_model="numpy")
def lu_solve_pair(a, rhs_a, rhs_b, out_a, out_b):
    """Solve a x = rhs_a and a x = rhs_b for one n x n matrix (LU, partial pivoting).

    ``a`` is overwritten by its factors. Returns False when a pivot is exactly zero (singular,
    as LAPACK's ``gesv`` behind ``np.linalg.solve``), the outputs then undefined.
    """
    n = a.shape[0]
    perm = np.arange(n)
    for k in range(n):
        pivot = k
        best = abs(a[k, k])
        for r in range(k + 1, n):
            if abs(a[r, k]) > best:
                best = abs(a[r, k])
                pivot = r
        if pivot != k:
            for c in range(n):
                a[k, c], a[pivot, c] = a[pivot, c], a[k, c]
            perm[k], perm[pivot] = perm[pivot], perm[k]
        if a[k, k] == 0.0:
            return False
        for r in range(k + 1, n):
            a[r, k] /= a[k, k]
            for c in range(k + 1, n):
                a[r, c] -= a[r, k] * a[k, c]
    for r in range(n):
        out_a[r] = rhs_a[perm[r]]
        out_b[r] = rhs_b[perm[r]]
    for r in range(n):  # forward substitution, unit lower factor
        for c in range(r):
            out_a[r] -= a[r, c] * out_a[c]
            out_b[r] -= a[r, c] * out_b[c]
    for r in range(n - 1, -1, -1):  # back substitution
        for c in range(r + 1, n):
            out_a[r] -= a[r, c] * out_a[c]
            out_b[r] -= a[r, c] * out_b[c]
        out_a[r] /= a[r, r]
        out_b[r] /= a[r, r]
    return True


@njit(cache=True, error_model="numpy")
def newton_step(res, nut_res, jac, nut, free, dz, de):
    """Newton step of the bordered system with the sphere blocks eliminated (Schur complement).

    Sphere blocks shifted by DIAGONAL_SHIFT |diagonal| and the nut terms scaled by
    (1 + DIAGONAL_SHIFT), as the reference's ``_damped_step``; only the first ``free`` unknowns
    of each sphere move (the rates are frozen at zero speed). Writes dz (B, 6) and de (2,).

    Returns:
        False when a sphere block is exactly singular.
    """
    count = res.shape[0]
    block = np.empty((free, free))
    rhs_r = np.empty(free)
    rhs_e = np.empty(free)
    inv_r = np.empty((count, free))
    inv_e = np.empty((count, free))
    sol_r = np.empty(free)
    sol_e = np.empty(free)
    schur = np.zeros(2)
    coupling = np.zeros(2)
    for i in range(count):
        for r in range(free):
            shift = DIAGONAL_SHIFT * (abs(jac[i, r, r]) + 1e-30)
            for c in range(free):
                block[r, c] = jac[i, r, c]
            block[r, r] += shift
            rhs_r[r] = res[i, r]
            rhs_e[r] = jac[i, r, 6]
        if not lu_solve_pair(block, rhs_r, rhs_e, sol_r, sol_e):
            return False
        k = nut[i]
        schur[k] += jac[i, 6, 6] * (1.0 + DIAGONAL_SHIFT)
        for r in range(free):
            inv_r[i, r] = sol_r[r]
            inv_e[i, r] = sol_e[r]
            schur[k] -= jac[i, 6, r] * sol_e[r]
            coupling[k] += jac[i, 6, r] * sol_r[r]
    for k in range(2):
        rhs = -nut_res[k] + coupling[k]
        de[k] = rhs / schur[k] if schur[k] != 0.0 else 0.0
    for i in range(count):
        for r in range(6):
            dz[i, r] = -(inv_r[i, r] + inv_e[i, r] * de[nut[i]]) if r < free else 0.0
    return True


# ----------------------------------------------------------------------------- Newton
@njit(cache=True, error_model="numpy")
def newton_kernel(
    z, e_nut, jac, reuse, nut, weight, gravity, loads, scales, inertial_terms, tolerance, scene
):
    """Damped Newton iteration of the steady state from (z, e_nut), updated in place.

    Args:
        z: (B, 6) sphere unknowns (n, b [m], w_B, omega_t,n,b [rad/s]), start and result.
        e_nut: (2,) nut offsets [m], start and result.
        jac: (B, 7, 7) sphere Jacobian blocks (see :func:`linearise`), in and out: the last
            ones computed.
        reuse: ``jac`` holds blocks of a nearby state (a warm start): take steps with them while
            each cuts the squared residual by CHORD_DECREASE at least, and compute them afresh
            when one does not. False: exact blocks at every iterate, as the reference.
        nut: (B,) int64 nut of each sphere; weight: (B,) spheres it stands for [-].
        gravity: (B, 3) [m/s^2] in Frenet components; loads: (2,) force the spheres must exert
            on each nut along +z [N]; scales: (force [N], moment [N m], nut [N]) scales of the
            residual rows; inertial_terms: see :func:`sphere_balance`; tolerance: on the worst
            scaled residual [-]; scene: ``scene_arrays(scene)`` as a float64 array.

    Returns:
        (iterations, worst scaled residual [-], status (STATUS_*), Jacobian evaluations,
        active (B, 4) and contact buffer (N_ROWS, B, 4) of ``contacts_kernel`` at the returned
        state).
    """
    count = z.shape[0]
    free = 2 if scene[_I_SCREW_SPEED] == 0.0 else 6  # rates frozen at zero speed
    args = (nut, weight, gravity, loads, scales, inertial_terms, scene)
    res = np.empty((count, 6))
    trial_res = np.empty((count, 6))
    axial = np.empty(count)
    dz = np.empty((count, 6))
    de = np.empty(2)
    trial_z = np.empty((count, 6))
    trial_e = np.empty(2)
    if reuse:
        nut_res = residuals(z, e_nut, *args, res)
        linearisations = 0
    else:
        nut_res = linearise(z, e_nut, *args, res, axial, jac)
        linearisations = 1
    fresh = not reuse  # jac belongs to the current iterate
    status = STATUS_NOT_CONVERGED
    iterations = NEWTON_MAX_ITER
    for iteration in range(NEWTON_MAX_ITER + 1):
        worst = _worst(res, nut_res, free)
        # Steps with old blocks converge linearly: they go on to CHORD_POLISH times the
        # tolerance (a Newton step lands there anyway), as long as each still cuts the residual.
        polishing = reuse and worst < tolerance
        if worst < (tolerance * CHORD_POLISH if reuse else tolerance) or (
            polishing and iteration == NEWTON_MAX_ITER
        ):
            status = STATUS_CONVERGED
            iterations = iteration
            break
        if iteration == NEWTON_MAX_ITER:
            break
        if not fresh and not reuse:
            nut_res = linearise(z, e_nut, *args, res, axial, jac)
            linearisations += 1
            fresh = True
        base = _merit(res, nut_res, free)
        singular = False
        accepted = False
        while True:
            if not newton_step(res, nut_res, jac, nut, free, dz, de):
                singular = fresh
                if not fresh:  # old blocks singular: compute them here
                    nut_res = linearise(z, e_nut, *args, res, axial, jac)
                    linearisations += 1
                    fresh = True
                    continue
                break
            step = 1.0
            for attempt in range(LINE_SEARCH_STEPS):
                for i in range(count):
                    for r in range(6):
                        trial_z[i, r] = z[i, r] + step * dz[i, r]
                for k in range(2):
                    trial_e[k] = e_nut[k] + step * de[k]
                if attempt == 0 and not reuse:  # the full step is usually taken: linearise there
                    trial_nut = linearise(trial_z, trial_e, *args, trial_res, axial, jac)
                    linearisations += 1
                else:
                    trial_nut = residuals(trial_z, trial_e, *args, trial_res)
                finite = np.isfinite(trial_res).all() and np.isfinite(trial_nut).all()
                merit = _merit(trial_res, trial_nut, free)
                if not fresh:  # a step with old blocks must cut the residual well, at once
                    accepted = bool(finite and merit < CHORD_DECREASE * base)
                    break
                if finite and (merit < base or step < MIN_STEP):
                    accepted = True
                    break
                step *= 0.5
            if polishing and not accepted:  # converged; polishing no longer pays
                break
            if not (accepted or fresh):  # old blocks no longer good enough: compute them here
                nut_res = linearise(z, e_nut, *args, res, axial, jac)
                linearisations += 1
                fresh = True
                continue
            # The blocks now belong to the first trial point (reference iteration, taken when it
            # is the new iterate) or to an earlier iterate (reuse).
            fresh = accepted and not reuse and step == 1.0
            break
        if polishing and not accepted:
            status = STATUS_CONVERGED
            iterations = iteration
            break
        if singular:
            status = STATUS_SINGULAR
            iterations = iteration
            break
        if not accepted:
            status = STATUS_NOT_FINITE
            iterations = iteration
            break
        z[:] = trial_z
        e_nut[:] = trial_e
        res[:] = trial_res
        nut_res = trial_nut
    ball_nb = np.ascontiguousarray(z[:, :2])
    kinematics = np.ascontiguousarray(z[:, 2:])
    e_ball = np.empty(count)
    for i in range(count):
        e_ball[i] = e_nut[nut[i]]
    active, out = contacts_kernel(
        ball_nb,
        kinematics,
        e_ball,
        gravity,
        np.zeros((0, 3)),
        np.zeros(count),
        np.zeros((0, 4)),
        False,
        *scene_from_array(scene),
    )
    return iterations, worst, status, linearisations, active, out


# ----------------------------------------------------------------------------- Python side
_checked_cache = False


def ensure_fresh_cache() -> bool:
    """Recompile this module's kernels (dropping their numba cache) if contacts.py, dual.py or
    the solver constants changed since they were cached; checked once per process.

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
            _worst,
            _merit,
            lu_solve_pair,
            newton_step,
            linearise,
            residuals,
            newton_kernel,
            frozen_constants,
            compiled_stamp,
        ):
            dispatcher.recompile()
    _checked_cache = True
    return stale


def solve_compiled(
    z: FloatArray,
    nut_offset: FloatArray,
    jacobian: FloatArray,
    reuse: bool,
    nut: NDArray[np.int64],
    weight: FloatArray,
    gravity: FloatArray,
    loads: FloatArray,
    scales: tuple[float, float, float],
    inertial_terms: bool,
    tolerance: float,
    scene: FloatArray,
) -> tuple[int, float, int, int, ContactEvaluation]:
    """Run :func:`newton_kernel` (``z`` (B, 6), ``nut_offset`` (2,) and ``jacobian``
    (B, 7, 7) updated in place; arguments as there).

    Returns:
        (iterations, worst scaled residual [-], status, Jacobian evaluations, contact
        evaluation at the result).
    """
    ensure_fresh_cache()
    iterations, worst, status, linearisations, active, out = newton_kernel(
        z,
        nut_offset,
        jacobian,
        reuse,
        nut,
        weight,
        gravity,
        loads,
        scales,
        inertial_terms,
        tolerance,
        scene,
    )
    evaluation = evaluation_from_buffer(active, out)
    return int(iterations), float(worst), int(status), int(linearisations), evaluation
