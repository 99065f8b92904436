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
- the rest is the iteration of the readable reference (``models.steady_reference``): the same
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

The parts live in their own modules: one sphere's balance, residuals and Jacobian block in
:mod:`~ballscrew_twin.kernels.steady_sphere`, the block factors and the Schur elimination in
:mod:`~ballscrew_twin.kernels.steady_linear`, the completed contacts and the sums in
:mod:`~ballscrew_twin.kernels.steady_results`; this module holds the iteration
(:func:`newton_kernel`), the warm-start predictor (:func:`extrapolate`) and the Python entry
(:func:`solve_compiled`).

numba's cache sees a change of this file only; :data:`DEPENDENCY_STAMP` (a hash of contacts.py,
dual.py, the three modules above and the solver constants) is frozen into the cache and
:func:`ensure_fresh_cache` recompiles once when it is stale.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit
from numpy.typing import NDArray

from . import contacts as _contacts_module
from . import dual as _dual_module
from . import steady_linear as _linear_module
from . import steady_results as _results_module
from . import steady_sphere as _sphere_module
from .cache_stamp import dependency_stamp
from .contacts import N_ROWS
from .solver_settings import DIAGONAL_SHIFT, LINE_SEARCH_STEPS, MIN_STEP, NEWTON_MAX_ITER
from .steady_linear import factorise, lu_factor, lu_solve, newton_step
from .steady_results import STATE_ROWS, SUMMARY_SIZE, finish_contacts, summarise
from .steady_sphere import I_SCREW_SPEED, linearise, residuals

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
DEPENDENCY_STAMP = dependency_stamp(
    (_contacts_module, _dual_module, _sphere_module, _linear_module, _results_module),
    SOLVER_CONSTANTS,
)


@njit(cache=True)
def compiled_stamp():
    """DEPENDENCY_STAMP as it was when the cached machine code was compiled."""
    return DEPENDENCY_STAMP


@njit(cache=True)
def frozen_constants():
    """The solver constants as the cached machine code sees them: SOLVER_CONSTANTS."""
    return SOLVER_CONSTANTS


# ----------------------------------------------------------------------------- residual norms
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
def extrapolate(old, last, fraction, speed, ball_nb, kinematics, nut_offset):
    """Warm start on the line through two solutions (``models.steady_compiled.predicted_start``):
    the compiled form of :func:`ballscrew_twin.models.steady_types.along_line`.

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
    free = 2 if scene[I_SCREW_SPEED] == 0.0 else 6  # rates frozen at zero speed
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


def evaluate_compiled(
    z: FloatArray,
    nut_offset: FloatArray,
    nut: NDArray[np.int64],
    weight: FloatArray,
    gravity: FloatArray,
    loads: FloatArray,
    scales: tuple[float, float, float],
    inertial_terms: bool,
    scene: FloatArray,
    partials: bool,
) -> tuple[FloatArray, FloatArray, FloatArray | None]:
    """One evaluation of the scaled residuals at (``z`` (B, 6), ``nut_offset`` (2,) [m]), the
    other arguments as :func:`newton_kernel`'s: (sphere residuals (B, 6), nut residuals (2,),
    the exact sphere Jacobian blocks (B, 7, 7) of :func:`linearise` when ``partials``, else
    None). The pseudo-arclength curve of :mod:`ballscrew_twin.models.steady_fold` uses it."""
    if not _checked_cache:
        ensure_fresh_cache()
    count = z.shape[0]
    args = (nut, weight, gravity, loads, scales, inertial_terms, scene)
    res = np.empty((count, 6))
    if partials:
        jac = np.empty((count, 7, 7))
        nut_res = linearise(z, nut_offset, *args, res, np.empty(count), jac)
        return res, nut_res, jac
    active = np.zeros((count, 4), dtype=np.bool_)
    out = np.zeros((N_ROWS, count, 4))
    return res, residuals(z, nut_offset, *args, res, active, out), None
