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
- the blocks' LU factors and the Schur complements are computed once per set of blocks
  (:func:`factorise`) and serve every step taken with them (:func:`newton_step`): a warm solve
  reuses the last solve's blocks (chord steps) and factorises them once, and refreshes them at
  a trial point when the chord steps converge slowly (``CHORD_SLOW``);
- the rest is the iteration of the readable reference ``SteadyStateModel._newton``: the same
  scaled residuals, the same diagonal shift of the blocks, the same frozen rates at zero speed,
  the same backtracking line search on the squared residual and the same stopping rule;
- what the solution implies is taken in the same call: the plain residual evaluations record
  every active contact's quantities in the layout of ``contacts_kernel`` (the accepted
  iterate's record is kept), :func:`finish_contacts` adds the inactive contacts, gravity and
  inertia, and :func:`summarise` sums the mechanism powers, the nuts' powers, the direct moment
  on the screw and gravity's power on the spheres and lays out the per-contact states, so that
  no evaluation after convergence and no numpy sums remain for the Python side.

The readable reference (``backend="reference"``: numpy contact laws, Python Newton with a
central-difference Jacobian) stays the definition; test/kernels/test_steady_solver.py checks that
the solutions agree to 1e-9 relative over the envelope. Units: SI throughout (m, rad/s, N, N m).

numba's cache sees a change of this file only; :data:`DEPENDENCY_STAMP` (a hash of contacts.py,
dual.py and the solver constants) is frozen into the cache and :func:`ensure_fresh_cache`
recompiles once when it is stale.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit, types
from numba.extending import overload
from numpy.typing import NDArray

from . import contacts as _contacts_module
from . import dual as _dual_module
from .cache_stamp import dependency_stamp
from .contacts import (
    F_ANGLE,
    F_APPROACH,
    F_DISS_LUBRICANT,
    F_FILM,
    F_FRICTION_DRY,
    F_FRICTION_LUB,
    F_GROOVE_MZ,
    F_LOAD_SHARE,
    F_MAX_PRESSURE,
    F_SEMI_X,
    F_SEMI_Y,
    F_SHEAR_STRESS,
    F_SLIP,
    F_STIFFNESS,
    F_TALLIAN,
    IS_NUT,
    N_FIELDS,
    N_ROWS,
    R_FORCE,
    R_GROOVE_FORCE,
    R_MOMENT,
    _add,
    _cross,
    _dot,
    _helical,
    _scale,
    _sub,
    contact_geometry,
    contact_law,
    law_constants,
    scene_from_array,
)
from .dual import make_dual
from .solver_settings import DIAGONAL_SHIFT, LINE_SEARCH_STEPS, MIN_STEP, NEWTON_MAX_ITER

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
#: with exact blocks, a step from an iterate whose worst scaled residual is below this lands
#: below the tolerance (quadratic convergence): its trial point is evaluated without partials,
#: and they are computed there only if it does not converge after all [-]
NEWTON_FINAL = 1e-6
#: a step with old blocks that cuts the worst scaled residual by less than this factor is slow
#: (linear convergence): the next trial point is evaluated with partials, so that the blocks are
#: those of the iterate from then on (and of the solution for the next warm solve) [-]
CHORD_SLOW = 0.01

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
    NEWTON_FINAL,
    CHORD_SLOW,
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
    """The solver constants as the cached machine code sees them: SOLVER_CONSTANTS."""
    return SOLVER_CONSTANTS


# ----------------------------------------------------------------------------- one sphere
def _record_contact(out, i, j, fields, on_groove):
    """Store one contact's CONTACT_FIELDS and groove force into ``out[:, i, j]`` (compiled
    only, see its overload: a no-op for dual numbers, whose value parts are not recorded)."""


def _record_sums(out, i, force, moment):
    """Store a sphere's summed contact force and moment into column 0 of the R_FORCE and
    R_MOMENT rows of ``out`` (compiled only; a no-op for dual numbers)."""


def _all_float(values):
    return all(isinstance(t, types.Float) for t in values.types)


@overload(_record_contact)
def _record_contact_impl(out, i, j, fields, on_groove):
    if not (_all_float(fields) and _all_float(on_groove)):
        return lambda out, i, j, fields, on_groove: None

    def store(out, i, j, fields, on_groove):
        for k in range(N_FIELDS):
            out[k, i, j] = fields[k]
        for k in range(3):
            out[R_GROOVE_FORCE + k, i, j] = on_groove[k]

    return store


@overload(_record_sums)
def _record_sums_impl(out, i, force, moment):
    if not (_all_float(force) and _all_float(moment)):
        return lambda out, i, force, moment: None

    def store(out, i, force, moment):
        for k in range(3):
            out[R_FORCE + k, i, 0] = force[k]
            out[R_MOMENT + k, i, 0] = moment[k]

    return store


@njit(inline="always")
def sphere_balance(
    n_i, b_i, e, w_ball, omega, gravity, constants, masses, inertial_terms, record, i, active, out
):
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
        record: store, for sphere ``i``, which contacts are active into ``active`` (B, 4) and,
            for float states, the active contacts' CONTACT_FIELDS and groove forces and the
            summed contact force and moment into ``out`` (N_ROWS, B, 4), the layout of
            ``contacts_kernel`` (its inactive contacts are left to :func:`finish_contacts`).

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
        if record:
            active[i, j] = geometry[4]
        if not geometry[4]:  # an inactive contact exerts nothing
            continue
        on_ball, moment, on_groove, fields = contact_law(
            j, constants, geometry, n_i, b_i, w_ball, omega, r_ball, v_centre, 0.0
        )
        if record:
            _record_contact(out, i, j, fields, on_groove)
        f_sum = _add(f_sum, on_ball)
        m_sum = _add(m_sum, moment)
        if IS_NUT[j]:
            on_nut = _add(on_nut, on_groove)
    if record:
        _record_sums(out, i, f_sum, m_sum)
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
    no_active = np.zeros((0, 4), dtype=np.bool_)
    no_out = np.zeros((0, 0, 4))
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
            False,
            i,
            no_active,
            no_out,
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
def residuals(
    z, e_nut, nut, weight, gravity, loads, scales, inertial_terms, scene, res, active, out
):
    """Scaled sphere residuals into ``res`` (B, 6) and the (2,) nut residuals returned, as
    :func:`linearise` without the partials; the contacts recorded into ``active`` (B, 4) and
    ``out`` (N_ROWS, B, 4) as :func:`sphere_balance` says (what :func:`finish_contacts`
    completes into the buffer of ``contacts_kernel``)."""
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
            True,
            i,
            active,
            out,
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
def lu_factor(a, perm):
    """LU factors of one n x n matrix with partial pivoting, in place: ``a`` becomes the unit
    lower factor (below the diagonal) and the upper one, ``perm`` (n,) the row order.

    Returns False when a pivot is exactly zero (singular, as LAPACK's ``gesv`` behind
    ``np.linalg.solve``), the factors then undefined.
    """
    n = a.shape[0]
    for r in range(n):
        perm[r] = r
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
    return True


@njit(cache=True, error_model="numpy")
def lu_solve(a, perm, rhs, out):
    """Solve A x = rhs into ``out`` with the factors ``a``, ``perm`` of :func:`lu_factor`."""
    n = a.shape[0]
    for r in range(n):
        out[r] = rhs[perm[r]]
    for r in range(n):  # forward substitution, unit lower factor
        for c in range(r):
            out[r] -= a[r, c] * out[c]
    for r in range(n - 1, -1, -1):  # back substitution
        for c in range(r + 1, n):
            out[r] -= a[r, c] * out[c]
        out[r] /= a[r, r]


@njit(cache=True, error_model="numpy")
def factorise(jac, nut, free, lu, perm, inv_e, schur):
    """Factors of the Newton matrix with the sphere blocks ``jac`` (B, 7, 7), for
    :func:`newton_step`: each shifted block's LU factors into ``lu`` (B, free, free) and
    ``perm`` (B, free), J_i^-1 C_i into ``inv_e`` (B, free) and each nut's Schur complement
    S_k = sum_i (G_i (1 + DIAGONAL_SHIFT) - A_i J_i^-1 C_i) into ``schur`` (2,).

    Sphere blocks are shifted by DIAGONAL_SHIFT |diagonal| and the nut terms scaled by
    (1 + DIAGONAL_SHIFT), as the reference's ``_damped_step``; only the first ``free`` unknowns
    of each sphere move (the rates are frozen at zero speed). The factors serve every step
    taken with the same blocks (computed once per solve when they are reused).

    Returns:
        False when a sphere block is exactly singular.
    """
    rhs_e = np.empty(free)
    schur[0] = 0.0
    schur[1] = 0.0
    for i in range(jac.shape[0]):
        block = lu[i]
        for r in range(free):
            shift = DIAGONAL_SHIFT * (abs(jac[i, r, r]) + 1e-30)
            for c in range(free):
                block[r, c] = jac[i, r, c]
            block[r, r] += shift
            rhs_e[r] = jac[i, r, 6]
        if not lu_factor(block, perm[i]):
            return False
        lu_solve(block, perm[i], rhs_e, inv_e[i])
        k = nut[i]
        schur[k] += jac[i, 6, 6] * (1.0 + DIAGONAL_SHIFT)
        for r in range(free):
            schur[k] -= jac[i, 6, r] * inv_e[i, r]
    return True


@njit(cache=True, error_model="numpy")
def newton_step(res, nut_res, jac, nut, free, lu, perm, inv_e, schur, inv_r, dz, de):
    """Newton step of the bordered system with the sphere blocks eliminated (Schur complement),
    from the factors of :func:`factorise`: de_k = (-g_k + sum_i A_i J_i^-1 r_i) / S_k,
    dz_i = -(J_i^-1 r_i + J_i^-1 C_i de_k). Writes dz (B, 6) and de (2,); ``inv_r`` (B, free)
    is scratch."""
    count = res.shape[0]
    coupling = np.zeros(2)
    for i in range(count):
        lu_solve(lu[i], perm[i], res[i, :free], inv_r[i])
        k = nut[i]
        for r in range(free):
            coupling[k] += jac[i, 6, r] * inv_r[i, r]
    for k in range(2):
        rhs = -nut_res[k] + coupling[k]
        de[k] = rhs / schur[k] if schur[k] != 0.0 else 0.0
    for i in range(count):
        for r in range(6):
            dz[i, r] = -(inv_r[i, r] + inv_e[i, r] * de[nut[i]]) if r < free else 0.0


# ----------------------------------------------------------------------------- results
#: rows of the per-contact states of :func:`summarise` (``ContactStates`` fields, one row each)
STATE_ROWS = (
    "normal_force",
    "friction_force",
    "contact_angle",
    "approach",
    "stiffness",
    "max_pressure",
    "semi_axis_x",
    "semi_axis_y",
    "film_thickness",
    "tallian_parameter",
    "load_share",
    "shear_stress",
    "lubricant_share",
    "dry_share",
    "slip_speed",
)
#: entries of the summary vector of :func:`summarise`
SUMMARY_POWER = 0  # 6 mechanism powers [W], models.base.MECHANISMS order
SUMMARY_NUT_POWER = 6  # 2 dissipated powers of the master and slave nut's spheres [W]
SUMMARY_DIRECT = 8  # sum of the moments of the spheres on the screw about its axis [N m]
SUMMARY_BALLS_POWER = 9  # power of gravity on the spheres [W]
#: the same over the screw speed, zero at standstill (``TwinOutput``'s torques, as
#: ``SteadyStateModel._assemble`` divides them, so that no division remains in Python)
SUMMARY_TORQUE = 10  # 6 mechanism torques [N m], models.base.MECHANISMS order
SUMMARY_NUT_TORQUE = 16  # 2 torques of the master and slave nut's spheres [N m]
SUMMARY_DRAG = 18  # drag torque, the mechanism torques summed in their order [N m]
SUMMARY_SIZE = 19


@njit(cache=True, error_model="numpy")
def finish_contacts(z, e_nut, nut, gravity, scene, active, out):
    """Complete the recorded contacts of the state (z, e_nut) into the buffer ``contacts_kernel``
    (steady use) returns for it: the laws of the inactive contacts (their states; they exert
    nothing) and gravity, centrifugal force and gyroscopic moment added to each sphere's force
    and moment, in that kernel's order of operations. Arguments as :func:`residuals`."""
    constants = law_constants(*scene_from_array(scene))
    ball_mass = scene[_I_BALL_MASS]
    ball_inertia = scene[_I_BALL_INERTIA]
    pitch_radius = constants[2]
    lead_rate = constants[3]
    zhat = constants[4]
    screw_speed = constants[10]
    for i in range(z.shape[0]):
        n_i, b_i, w_ball = z[i, 0], z[i, 1], z[i, 2]
        omega = (z[i, 3], z[i, 4], z[i, 5])
        r_ball = (0.0, n_i - pitch_radius, b_i)
        v_centre = _helical(w_ball, zhat, lead_rate, r_ball)
        for j in range(4):
            if active[i, j]:
                continue
            geometry = contact_geometry(j, constants, n_i, b_i, e_nut[nut[i]], 0.0)
            _, _, on_groove, fields = contact_law(
                j, constants, geometry, n_i, b_i, w_ball, omega, r_ball, v_centre, 0.0
            )
            _record_contact(out, i, j, fields, on_groove)
        orbit_rate = screw_speed + w_ball
        r_perp = _sub(r_ball, _scale(_dot(r_ball, zhat), zhat))
        inertial = _scale(ball_mass * orbit_rate * orbit_rate, r_perp)
        for k in range(3):
            out[R_FORCE + k, i, 0] = (
                out[R_FORCE + k, i, 0] + ball_mass * gravity[i, k] + inertial[k]
            )
        omega_abs = _add(omega, _scale(screw_speed, zhat))
        gyro = _scale(orbit_rate, _cross(zhat, _scale(ball_inertia, omega_abs)))
        for k in range(3):
            out[R_MOMENT + k, i, 0] = out[R_MOMENT + k, i, 0] - gyro[k]


@njit(cache=True, error_model="numpy")
def summarise(z, nut, weight, gravity, scene, active, out, summary, states):
    """What a steady solution implies, from its contact buffer (``contacts_kernel`` layout),
    written into ``summary`` and ``states``:

    - summary (SUMMARY_SIZE,): the mechanism powers [W] summed over the spheres times the
      spheres each stands for, the two nuts' dissipated powers [W], the spheres' direct moment
      on the screw about its axis [N m] and gravity's power on the spheres [W] (as
      ``SteadyStateModel._assemble`` and ``_potential_energy_rate``), and the mechanisms' and
      nuts' powers and the drag over the screw speed [N m] (zero at standstill);
    - states (len(STATE_ROWS), 4 B): the per-contact states of ``ContactStates``, one row per
      field, contact 4 i + j, zero where inactive except the contact angle and the stiffness.
    """
    count = z.shape[0]
    summary[:] = 0.0
    ball_mass = scene[_I_BALL_MASS]
    lead_rate = scene[3]
    z_t, z_b = scene[4], scene[5]  # screw axis (sin helix, 0, cos helix) in Frenet components
    pitch_radius = scene[2]
    screw_speed = scene[_I_SCREW_SPEED]
    for i in range(count):
        sphere_power = 0.0
        for j in range(4):
            for m in range(6):
                power = out[F_DISS_LUBRICANT + m, i, j]
                summary[SUMMARY_POWER + m] += power * weight[i]
                sphere_power += power
            if not IS_NUT[j]:
                summary[SUMMARY_DIRECT] -= out[F_GROOVE_MZ, i, j] * weight[i]
            c = 4 * i + j
            on = active[i, j]
            lubricant = out[F_FRICTION_LUB, i, j]
            friction = lubricant + out[F_FRICTION_DRY, i, j]
            share = lubricant / friction if friction > 0.0 else 0.0
            approach = out[F_APPROACH, i, j]
            stiffness = out[F_STIFFNESS, i, j]
            states[0, c] = stiffness * max(approach, 0.0) ** 1.5 if on else 0.0
            states[1, c] = friction if on else 0.0
            states[2, c] = out[F_ANGLE, i, j]
            states[3, c] = approach if on else 0.0
            states[4, c] = stiffness
            states[5, c] = out[F_MAX_PRESSURE, i, j] if on else 0.0
            states[6, c] = out[F_SEMI_X, i, j] if on else 0.0
            states[7, c] = out[F_SEMI_Y, i, j] if on else 0.0
            states[8, c] = out[F_FILM, i, j] if on else 0.0
            states[9, c] = out[F_TALLIAN, i, j] if on else 0.0
            states[10, c] = out[F_LOAD_SHARE, i, j] if on else 0.0
            states[11, c] = out[F_SHEAR_STRESS, i, j] if on else 0.0
            states[12, c] = share if on else 0.0
            states[13, c] = (1.0 - share if friction > 0.0 else 0.0) if on else 0.0
            states[14, c] = out[F_SLIP, i, j] if on else 0.0
        summary[SUMMARY_NUT_POWER + nut[i]] += sphere_power * weight[i]
        # Gravity's power on sphere i: v = (w_B + Omega) z x r + w_B p/(2 pi) z, r = (0, r_n, b).
        r_n = z[i, 0] - pitch_radius
        r_b = z[i, 1]
        w_ball = z[i, 2]
        orbit_rate = w_ball + screw_speed
        along = w_ball * lead_rate
        g_dot_v = (
            gravity[i, 0] * (orbit_rate * (-z_b * r_n) + along * z_t)
            + gravity[i, 1] * (orbit_rate * (-z_t * r_b))
            + gravity[i, 2] * (orbit_rate * (z_t * r_n) + along * z_b)
        )
        summary[SUMMARY_BALLS_POWER] += weight[i] * g_dot_v
    summary[SUMMARY_BALLS_POWER] *= ball_mass
    if screw_speed != 0.0:
        for m in range(6):
            summary[SUMMARY_TORQUE + m] = summary[SUMMARY_POWER + m] / screw_speed
            summary[SUMMARY_DRAG] += summary[SUMMARY_TORQUE + m]
        for k in range(2):
            summary[SUMMARY_NUT_TORQUE + k] = summary[SUMMARY_NUT_POWER + k] / screw_speed


@njit(cache=True, error_model="numpy")
def extrapolate(old, last, fraction, speed, ball_nb, kinematics, nut_offset):
    """Warm start on the line through two solutions (``SteadyStateModel._predicted``); the
    compiled form of :func:`ballscrew_twin.models.steady.along_line`.

    Args:
        old, last: (ball_nb (B, 2) [m], kinematics (B, 4) [rad/s], nut_offset (2,) [m], screw
            speed [rad/s]) of the two solutions.
        fraction: s, the new point's place beyond ``last`` in units of their step [-].
        speed: screw speed of the new point [rad/s] (of the sign of both solutions' speeds).
        ball_nb, kinematics, nut_offset: out, the start: offsets moved by s times their step,
            rates over the speed (the rolling pattern) moved the same way, times ``speed``.
    """
    nb0, kin0, e0, speed0 = old
    nb1, kin1, e1, speed1 = last
    for i in range(nb1.shape[0]):
        for c in range(2):
            ball_nb[i, c] = nb1[i, c] + fraction * (nb1[i, c] - nb0[i, c])
        for c in range(4):
            per_speed = kin1[i, c] / speed1
            kinematics[i, c] = (per_speed + fraction * (per_speed - kin0[i, c] / speed0)) * speed
    for k in range(2):
        nut_offset[k] = e1[k] + fraction * (e1[k] - e0[k])


# ----------------------------------------------------------------------------- Newton
@njit(cache=True, error_model="numpy")
def newton_kernel(
    z,
    e_nut,
    jac,
    reuse,
    jac_scales,
    polished,
    nut,
    weight,
    gravity,
    loads,
    scales,
    inertial_terms,
    tolerance,
    scene,
    max_iterations,
    active_pair,
    out_pair,
    summary,
    states,
):
    """Damped Newton iteration of the steady state from (z, e_nut), updated in place, and what
    the solution implies, written into the last four arguments (allocated by the caller: a
    numba function returning arrays pays ~0.7 us per array to hand them to Python).

    Args:
        z: (B, 6) sphere unknowns (n, b [m], w_B, omega_t,n,b [rad/s]), start and result.
        e_nut: (2,) nut offsets [m], start and result.
        jac: (B, 7, 7) sphere Jacobian blocks (see :func:`linearise`), in and out: the last
            ones computed, in the residual scales ``scales``.
        reuse: ``jac`` holds blocks of a nearby state (a warm start), in the residual scales
            ``jac_scales`` (3,): take steps with them while each cuts the squared residual by
            CHORD_DECREASE at least, and compute them afresh when one does not; after a step
            that cuts the worst residual less than 1 / CHORD_SLOW-fold, the next trial point is
            evaluated with partials (its blocks serve the steps after it). False: exact
            blocks at every iterate, as the reference.
        polished: the start is a solution this solver returned (with ``reuse``, polished until
            a step with old blocks no longer cut the residual): it is accepted at once when
            below the tolerance (polishing it again would not cut the residual either).
        nut: (B,) int64 nut of each sphere; weight: (B,) spheres it stands for [-].
        gravity: (B, 3) [m/s^2] in Frenet components; loads: (2,) force the spheres must exert
            on each nut along +z [N]; scales: (force [N], moment [N m], nut [N]) scales of the
            residual rows; inertial_terms: see :func:`sphere_balance`; tolerance: on the worst
            scaled residual [-]; scene: ``scene_arrays(scene)`` as a float64 array;
            max_iterations: Newton iterations before giving up (NEWTON_MAX_ITER for a solve, fewer
            for a step of the start-up path).
        active_pair: (2, B, 4) bool zeros, out_pair: (2, N_ROWS, B, 4) zeros: the contacts of the
            iterate and of the trial point (the two swap when a trial point is accepted); the
            pair ``slot`` returned holds the active contacts and the contact buffer as
            ``contacts_kernel`` gives them at the returned state.
        summary: (SUMMARY_SIZE,) out and states: (len(STATE_ROWS), 4 B) out, :func:`summarise`
            of the returned state.

    Returns:
        (iterations, worst scaled residual [-], status (STATUS_*), Jacobian evaluations, slot).
    """
    count = z.shape[0]
    free = 2 if scene[_I_SCREW_SPEED] == 0.0 else 6  # rates frozen at zero speed
    args = (nut, weight, gravity, loads, scales, inertial_terms, scene)
    res = np.empty((count, 6))
    trial_res = np.empty((count, 6))
    axial = np.empty(count)  # scratch: linearise's weighted axial pushes
    dz = np.empty((count, 6))
    de = np.empty(2)
    # Factors of the Newton matrix of the blocks in jac (factorise), valid while "factored".
    lu = np.empty((count, free, free))
    perm = np.empty((count, free), dtype=np.int64)
    inv_e = np.empty((count, free))
    inv_r = np.empty((count, free))
    schur = np.empty(2)
    factored = False
    regular = True
    trial_z = np.empty((count, 6))
    trial_e = np.empty(2)
    # Contacts of the iterate and of the trial point; those of the iterate are "recorded" when
    # its residual came from residuals() (linearise records nothing).
    active = active_pair[0]
    out = out_pair[0]
    trial_active = active_pair[1]
    trial_out = out_pair[1]
    slot = 0  # the pair of active and out
    if reuse:
        for r in range(7):
            ratio = (
                jac_scales[0 if r < 3 else (1 if r < 6 else 2)]
                / scales[0 if r < 3 else (1 if r < 6 else 2)]
            )
            for i in range(count):
                for c in range(7):
                    jac[i, r, c] *= ratio
        nut_res = residuals(z, e_nut, *args, res, active, out)
        recorded = True
        linearisations = 0
    else:
        nut_res = linearise(z, e_nut, *args, res, axial, jac)
        recorded = False
        linearisations = 1
    fresh = not reuse  # jac belongs to the current iterate
    slow = False  # the last step with old blocks converged slowly: refresh them at the next
    status = STATUS_NOT_CONVERGED
    iterations = max_iterations
    worst = np.inf
    for iteration in range(max_iterations + 1):
        worst = _worst(res, nut_res, free)
        # Steps with old blocks converge linearly: they go on to CHORD_POLISH times the
        # tolerance (a Newton step lands there anyway), as long as each still cuts the residual.
        polishing = reuse and worst < tolerance
        if (
            worst < (tolerance * CHORD_POLISH if reuse else tolerance)
            or (polishing and iteration == max_iterations)
            or (polished and iteration == 0 and worst < tolerance)
        ):
            status = STATUS_CONVERGED
            iterations = iteration
            break
        if iteration == max_iterations:
            break
        if not fresh and not reuse:
            nut_res = linearise(z, e_nut, *args, res, axial, jac)
            linearisations += 1
            fresh = True
            factored = False
        base = _merit(res, nut_res, free)
        singular = False
        accepted = False
        trial_recorded = False
        trial_linearised = False
        while True:
            if not factored:
                regular = factorise(jac, nut, free, lu, perm, inv_e, schur)
                factored = True
            if not regular:
                singular = fresh
                if not fresh:  # old blocks singular: compute them here
                    nut_res = linearise(z, e_nut, *args, res, axial, jac)
                    linearisations += 1
                    fresh = True
                    slow = False
                    factored = False
                    continue
                break
            newton_step(res, nut_res, jac, nut, free, lu, perm, inv_e, schur, inv_r, dz, de)
            step = 1.0
            for attempt in range(LINE_SEARCH_STEPS):
                for i in range(count):
                    for r in range(6):
                        trial_z[i, r] = z[i, r] + step * dz[i, r]
                for k in range(2):
                    trial_e[k] = e_nut[k] + step * de[k]
                # The full step is usually taken: linearise there, unless it is the last one
                # (or, reusing blocks, unless the old blocks still converge fast).
                if attempt == 0 and ((not reuse and worst >= NEWTON_FINAL) or slow):
                    trial_nut = linearise(trial_z, trial_e, *args, trial_res, axial, jac)
                    linearisations += 1
                    factored = False
                    trial_recorded = False
                    trial_linearised = True
                else:
                    trial_nut = residuals(
                        trial_z, trial_e, *args, trial_res, trial_active, trial_out
                    )
                    trial_recorded = True
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
                slow = False
                factored = False
                continue
            # The blocks now belong to the first trial point (reference iteration, taken when it
            # is the new iterate) or to an earlier iterate (reuse, last step).
            slow = (
                reuse
                and accepted
                and not fresh
                and not trial_linearised
                and _worst(trial_res, trial_nut, free) > CHORD_SLOW * worst
            )
            fresh = accepted and trial_linearised and step == 1.0
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
        res, trial_res = trial_res, res
        nut_res = trial_nut
        if trial_recorded:
            active, trial_active = trial_active, active
            out, trial_out = trial_out, out
            slot = 1 - slot
        recorded = trial_recorded
    if not recorded:  # the last residual came from linearise: record the contacts here
        residuals(z, e_nut, *args, trial_res, active, out)
    finish_contacts(z, e_nut, nut, gravity, scene, active, out)
    summarise(z, nut, weight, gravity, scene, active, out, summary, states)
    return iterations, worst, status, linearisations, slot


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
            lu_factor,
            lu_solve,
            factorise,
            newton_step,
            linearise,
            residuals,
            finish_contacts,
            summarise,
            extrapolate,
            newton_kernel,
            frozen_constants,
            compiled_stamp,
        ):
            dispatcher.recompile()
    _checked_cache = True
    return stale


class KernelSolution(NamedTuple):
    """What :func:`newton_kernel` returns, typed."""

    iterations: int
    residual: float  # worst scaled residual [-]
    status: int  # STATUS_*
    linearisations: int
    active: NDArray[np.bool_]  # (B, 4)
    buffer: FloatArray  # (N_ROWS, B, 4), the layout of contacts_kernel
    summary: FloatArray  # (SUMMARY_SIZE,), see summarise
    states: FloatArray  # (len(STATE_ROWS), 4 B), see summarise


def solve_compiled(
    z: FloatArray,
    nut_offset: FloatArray,
    jacobian: FloatArray,
    reuse: bool,
    jacobian_scales: tuple[float, float, float],
    polished: bool,
    nut: NDArray[np.int64],
    weight: FloatArray,
    gravity: FloatArray,
    loads: FloatArray,
    scales: tuple[float, float, float],
    inertial_terms: bool,
    tolerance: float,
    scene: FloatArray,
    max_iterations: int,
) -> KernelSolution:
    """Run :func:`newton_kernel` (``z`` (B, 6), ``nut_offset`` (2,) and ``jacobian``
    (B, 7, 7) updated in place; arguments as there) on arrays allocated here."""
    if not _checked_cache:
        ensure_fresh_cache()
    count = z.shape[0]
    active = np.zeros((2, count, 4), dtype=np.bool_)
    buffer = np.zeros((2, N_ROWS, count, 4))
    summary = np.empty(SUMMARY_SIZE)
    states = np.empty((len(STATE_ROWS), 4 * count))
    iterations, residual, status, linearisations, slot = newton_kernel(
        z,
        nut_offset,
        jacobian,
        reuse,
        jacobian_scales,
        polished,
        nut,
        weight,
        gravity,
        loads,
        scales,
        inertial_terms,
        tolerance,
        scene,
        max_iterations,
        active,
        buffer,
        summary,
        states,
    )
    return KernelSolution(
        iterations,
        residual,
        status,
        linearisations,
        active[slot],
        buffer[slot],
        summary,
        states,
    )
