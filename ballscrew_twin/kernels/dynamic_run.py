"""The compiled time loop of the simulation runner (numba): many dynamic-model steps per call.

:func:`run_steps` loops :func:`~ballscrew_twin.kernels.dynamic_step.step_kernel` over the steps
of a stretch of a run (commands from the scenario's smooth steps) and accumulates what
:func:`ballscrew_twin.models.simulation.simulate` records per step (``_account``: the
finiteness checks, the input and gravitational power, the energy integrals over each step's own
length, the sums over the averaging window), so that a whole output interval is one call from
Python; a step with implicit sphere positions that does not converge is redone there as
semi-implicit substeps (``fallback``).

The machine code of ``step_kernel`` and ``contacts_kernel`` is frozen into this module's cache,
which numba invalidates only when this file changes; :data:`DEPENDENCY_STAMP` (a hash of
dynamic_step.py, its layouts and predictor, contacts.py and the solver constants) is frozen
with it and :func:`ensure_fresh_cache` recompiles once when it is stale. Everything is SI: m, s,
rad, N, N m, W, J.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from . import contacts as _contacts_module
from . import dynamic_layouts as _layouts_module
from . import dynamic_predictor as _predictor_module
from . import dynamic_step as _step_module
from .cache_stamp import dependency_stamp
from .dynamic_layouts import (
    B_NUT_VEL,
    B_SPEED,
    B_TIME,
    H_NEXT_TIME,
    J_VALID,
    K_DT,
    K_GX,
    K_GY,
    K_GZ,
    K_IMPLICIT,
    K_MASS,
    K_WEIGHT,
    N_BODY,
    N_MECHANISMS,
    S_COUNT,
    S_DISSIPATION,
    S_EVALS,
    S_ITERATIONS,
    S_JACOBIANS,
    S_MECHANISMS,
    S_MOTOR,
    S_NUT_DISSIPATION,
    S_RESIDUAL,
    S_SCREW_TORQUE,
    S_UNCONVERGED,
)
from .dynamic_step import SOLVER_CONSTANTS, step_kernel

#: frozen into the cached code by :func:`compiled_stamp`; compared at first use
DEPENDENCY_STAMP = dependency_stamp(
    (_contacts_module, _layouts_module, _predictor_module, _step_module), SOLVER_CONSTANTS
)


@njit(cache=True)
def compiled_stamp():
    """DEPENDENCY_STAMP as it was when the cached machine code was compiled."""
    return DEPENDENCY_STAMP


# Run accumulators (A_COUNT,) float64 of run_steps, carried from call to call: motor torque of
# the last step [N m]; cumulative input energy, gross input energy int |P_in| dt and dissipated
# energy [J] (trapezoid); input power and dissipation of the previous step [W] and 1 once there
# is one; window sums of motor torque [N m], screw speed [rad/s], gravitational power [W],
# step count [-], dissipation per mechanism (7) and per nut (2) [W]; work totals (contact
# evaluations, Jacobians, Newton iterations, unconverged steps) [-]; the last scaled residual
# [-]; the first step's gravitational power [W], input and dissipated energy after it [J]; on a
# non-finite value: 1 + index into FINITE_CHECKS of the quantity, its value and the step; the
# previous step's length [s] (the interval of the next trapezoid: the step may change between
# calls, simulation.py's start phase); the number of steps redone as fallback substeps [-].
(
    A_MOTOR,
    A_INPUT,
    A_ABS_INPUT,
    A_DISSIPATED,
    A_PREV_POWER,
    A_PREV_DISS,
    A_HAS_PREV,
    A_W_MOTOR,
    A_W_SPEED,
    A_W_GRAVITY,
    A_W_COUNT,
    A_W_MECHANISMS,
    A_W_NUTS,
    A_EVALS,
    A_JACOBIANS,
    A_ITERATIONS,
    A_UNCONVERGED,
    A_RESIDUAL,
    A_FIRST_GRAVITY,
    A_FIRST_INPUT,
    A_FIRST_DISSIPATED,
    A_FAILED,
    A_FAILED_VALUE,
    A_FAILED_STEP,
    A_PREV_DT,
    A_FALLBACKS,
) = (0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 18, 20, 21, 22, 23, 24, 25, 26, 27, 28, 29, 30, 31, 32)
A_COUNT = 33
#: Quantities checked for finiteness at every step, in the order of simulation._check_finite.
FINITE_CHECKS = (
    "screw speed",
    "motor torque",
    "dissipation",
    "screw torque",
    "nut velocity",
    "sphere velocity",
    "sphere angular velocity",
)


@njit(cache=True, error_model="numpy")
def _account(step, command, c, pos, vel, omega, body, stats, acc, window_first):
    """simulation.simulate's per-step bookkeeping of one step of length c[K_DT] [s] from the
    state (pos, vel, omega, body) with statistics ``stats``: the finiteness checks, the input
    power M Omega + F_p (v_1 - v_2), the trapezoid energy integrals over the last step's length,
    the window sums (run step ``step`` >= ``window_first``; ``step`` < 0: not a window sample)
    and the work counters. Returns the gravitational power [W]; on a non-finite value it sets
    acc[A_FAILED] (1 + its FINITE_CHECKS index) and returns NaN."""
    count = pos.shape[0]
    gx, gy, gz = c[K_GX], c[K_GY], c[K_GZ]
    sum_vel = 0.0
    sum_omega = 0.0
    gravity_power = 0.0
    for i in range(count):
        sum_vel += vel[i, 0] + vel[i, 1] + vel[i, 2]
        sum_omega += omega[i, 0] + omega[i, 1] + omega[i, 2]
        gravity_power -= c[K_MASS] * (vel[i, 0] * gx + vel[i, 1] * gy + vel[i, 2] * gz)
    nut_vel = body[B_NUT_VEL] + body[B_NUT_VEL + 1]
    gravity_power += c[K_WEIGHT] * nut_vel
    checks = (
        body[B_SPEED],
        stats[S_MOTOR],
        stats[S_DISSIPATION],
        stats[S_SCREW_TORQUE],
        nut_vel,
        sum_vel,
        sum_omega,
    )
    for j in range(len(checks)):
        if not np.isfinite(checks[j]):
            acc[A_FAILED] = 1.0 + j
            acc[A_FAILED_VALUE] = checks[j]
            return math.nan
    motor = acc[A_MOTOR]
    power_in = motor * body[B_SPEED] + command[1] * (body[B_NUT_VEL] - body[B_NUT_VEL + 1])
    diss = stats[S_DISSIPATION]
    if acc[A_HAS_PREV] > 0.0:
        interval = acc[A_PREV_DT]
        acc[A_INPUT] += 0.5 * interval * (acc[A_PREV_POWER] + power_in)
        acc[A_ABS_INPUT] += 0.5 * interval * (abs(acc[A_PREV_POWER]) + abs(power_in))
        acc[A_DISSIPATED] += 0.5 * interval * (acc[A_PREV_DISS] + diss)
    acc[A_PREV_POWER] = power_in
    acc[A_PREV_DISS] = diss
    acc[A_PREV_DT] = c[K_DT]
    acc[A_HAS_PREV] = 1.0
    if step >= window_first:
        acc[A_W_MOTOR] += motor
        acc[A_W_SPEED] += body[B_SPEED]
        acc[A_W_GRAVITY] += gravity_power
        acc[A_W_COUNT] += 1.0
        for j in range(N_MECHANISMS):
            acc[A_W_MECHANISMS + j] += stats[S_MECHANISMS + j]
        for j in range(2):
            acc[A_W_NUTS + j] += stats[S_NUT_DISSIPATION + j]
    acc[A_EVALS] += stats[S_EVALS]
    acc[A_JACOBIANS] += stats[S_JACOBIANS]
    acc[A_ITERATIONS] += stats[S_ITERATIONS]
    acc[A_UNCONVERGED] += stats[S_UNCONVERGED]
    acc[A_RESIDUAL] = stats[S_RESIDUAL]
    acc[A_MOTOR] = stats[S_MOTOR]
    return gravity_power


@njit(cache=True, error_model="numpy")
def run_steps(
    first_step,
    window_first,
    final_step,
    commands,
    pos,
    vel,
    omega,
    theta,
    body,
    ball_nut,
    c,
    p,
    sphere_offset,
    spalls,
    jam_start,
    jac_own,
    jac_shared,
    jac_active,
    jac_meta,
    history,
    history_meta,
    acc,
    first_stats,
    fallback,
    fine_step,
):
    """Steps ``first_step`` .. ``first_step + n - 1`` of a run (n = len(commands)), each as
    simulation.simulate's per-step loop does with step_kernel: the step, the finiteness checks,
    the input power M Omega + F_p (v_1 - v_2) and gravitational power, the trapezoid energy
    integrals and the sums over the averaging window (steps >= ``window_first``). Step
    ``final_step`` is the run's end: as in that loop, its first (sub)step is accounted (the
    power at the end time closes the last trapezoid) and the state is not advanced past it; a
    fallback there must not integrate its further substeps beyond the run's end.

    Args:
        commands: (n, 2) speed reference [rad/s] and preload [N] of each step.
        pos, vel, omega, theta, body: the state (layouts of step_kernel), advanced in place.
        jam_start: (B,) time from which each sphere's rotation is blocked [s] (inf: never).
        acc: (A_COUNT,) run accumulators (layout A_*), updated; first_stats: (S_COUNT,) the
            first step's statistics (written). Other arguments: see step_kernel.
        fallback: a step that does not converge (with implicit sphere positions) is redone from
            its start as this many semi-implicit steps of ``fine_step`` [s] with its commands
            (1: never); the discarded attempt's work is counted, the kept Jacobian and the
            predictor's history dropped before and after.

    Returns:
        active (B, 4) and the contact kernel's buffer of the first step (for the records).
        Stops at the first non-finite value (acc[A_FAILED] = 1 + its FINITE_CHECKS index).
    """
    count = pos.shape[0]
    jammed = np.zeros(count, dtype=np.bool_)
    new_pos, new_vel, new_omega = np.empty((count, 3)), np.empty((count, 3)), np.empty((count, 3))
    new_theta, new_body = np.empty(count), np.empty(N_BODY)
    stats = np.zeros(S_COUNT)
    first_active = np.zeros((count, 4), dtype=np.bool_)
    first_out = np.zeros((1, count, 4))
    fine_c = c.copy()
    fine_c[K_DT] = fine_step
    fine_c[K_IMPLICIT] = 0.0
    for n in range(commands.shape[0]):
        parts = 1
        step_c = c
        j = 0
        while j < parts:
            for i in range(count):
                jammed[i] = body[B_TIME] >= jam_start[i]
            active, out = step_kernel(
                pos, vel, omega, theta, body, commands[n], ball_nut, step_c, p, sphere_offset,
                spalls, jammed, jac_own, jac_shared, jac_active, jac_meta, history, history_meta,
                new_pos, new_vel, new_omega, new_theta, new_body, stats,
            )  # fmt: skip
            if parts == 1 and fallback > 1 and c[K_IMPLICIT] != 0.0 and stats[S_UNCONVERGED] > 0.0:
                acc[A_EVALS] += stats[S_EVALS]
                acc[A_JACOBIANS] += stats[S_JACOBIANS]
                acc[A_ITERATIONS] += stats[S_ITERATIONS]
                acc[A_FALLBACKS] += 1.0
                jac_meta[J_VALID] = 0
                history_meta[H_NEXT_TIME] = math.nan
                parts = fallback
                step_c = fine_c
                continue
            sample = first_step + n if j == 0 else -1
            gravity_power = _account(
                sample, commands[n], step_c, pos, vel, omega, body, stats, acc, window_first
            )
            if acc[A_FAILED] > 0.0:
                acc[A_FAILED_STEP] = first_step + n
                return first_active, first_out
            if n == 0 and j == 0:
                first_stats[:] = stats
                first_active = active
                first_out = out
                acc[A_FIRST_GRAVITY] = gravity_power
                acc[A_FIRST_INPUT] = acc[A_INPUT]
                acc[A_FIRST_DISSIPATED] = acc[A_DISSIPATED]
            if first_step + n == final_step:
                return first_active, first_out
            pos[:, :] = new_pos
            vel[:, :] = new_vel
            omega[:, :] = new_omega
            theta[:] = new_theta
            body[:] = new_body
            j += 1
        if parts > 1:  # back to the run's step
            jac_meta[J_VALID] = 0
            history_meta[H_NEXT_TIME] = math.nan
    return first_active, first_out


# ----------------------------------------------------------------------------- cache
_checked_cache = False


def ensure_fresh_cache() -> bool:
    """Make the step kernel's cache fresh, then recompile this module's kernels once when their
    cache predates dynamic_step.py, contacts.py or the constants. True when this module's were
    recompiled."""
    global _checked_cache
    _step_module.ensure_fresh_cache()
    if _checked_cache:
        return False
    stale = bool(compiled_stamp() != DEPENDENCY_STAMP)
    if stale:
        for dispatcher in (_account, run_steps, compiled_stamp):
            dispatcher.recompile()
    _checked_cache = True
    return stale
