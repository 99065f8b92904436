"""Compiled time step of the dynamic model (numba): the twin of ``DynamicModel._step``.

:func:`step_kernel` performs one step of :meth:`ballscrew_twin.models.dynamic.DynamicModel._step`
operation for operation, with the contact laws of
:mod:`ballscrew_twin.kernels.contacts` and no Python in the step:

- the spheres are located on the helix once (Newton on (r - B(theta)) . dB/dtheta = 0, Eq. 4;
  ``_locate``), the defect offsets of the approach follow (``_approach_offsets``, as
  :meth:`Faults.approach_offsets`);
- the velocity-independent part of the contact laws once per step (``_statics``:
  :func:`~ballscrew_twin.kernels.contacts.contacts_statics_kernel`, geometry, Hertz ellipse and
  stiffness, contact normal and point, pressure viscosity; the positions do not move within a
  step);
- contact actions at given velocities (``_actions``): velocities relative to the screw in each
  sphere's Frenet frame, the rest of the contact laws from the step's statics
  (:func:`~ballscrew_twin.kernels.contacts.contacts_kinetics_kernel`, bit for bit
  ``contacts_kernel``'s dynamic path), forces and moments back to the world frame, each
  sphere's moment on the screw and axial force on its nut;
- Newton's first guess (``_predict``, ``_remember``): the velocities extrapolated from the
  starts of the last steps (kept in caller-owned arrays) at the order, 0 to PREDICTOR_ORDER,
  that predicted the last step best; a guess that meets the tolerance ends the step;
- the velocity Jacobian by forward differences (``_jacobians``: 6 + 1 + 1 evaluations), kept
  between steps in caller-owned arrays and refreshed as the reference does (when a correction
  is needed and the kept one is older than ``jacobian_interval`` steps or the contact set
  changed, and at a Newton iterate that contracted the residual too little);
- the backward-Euler residuals and their scaled maximum (``_residual``), the Newton correction
  by elimination of the 6 x 6 sphere blocks and a 3 x 3 Schur complement (``_correction``; small
  LU with partial pivoting instead of LAPACK), the Newton loop with backtracking, and the
  position update x_{n+1} = x_n + dt u_{n+1};
- with implicit sphere positions (c[K_IMPLICIT] = 1) every evaluation of the step puts the
  spheres at x_n + dt v and the screw at phi_n + dt Omega first (``_place``: located, offsets
  and statics again; ``_evaluate``),
  so the contact actions are those at the end-of-step positions and the Jacobian columns the
  total derivatives (docs/model.md section 10).

Results agree with the reference to rounding (different summation order in a few sums and a
different LU): test/kernels/test_dynamic_step.py runs both side by side.

:func:`run_steps` loops :func:`step_kernel` over many steps (commands from the scenario's
smooth steps) and accumulates what the simulation runner records per step (energy integrals
over each step's own length, window sums; ``_account``), so that a whole output interval is
one call from Python; a step with implicit sphere positions that does not converge is redone
there as semi-implicit substeps (``fallback``).

numba freezes the solver constants (:mod:`ballscrew_twin.kernels.solver_settings`) and the
machine code of ``contacts_kernel`` into the cache, which is invalidated only by a change of this
file; :data:`DEPENDENCY_STAMP` (a hash of contacts.py and the constants) is frozen with them and
:func:`ensure_fresh_cache` recompiles once when it is stale (as kernels/steady_newton.py).
Everything is SI: m, s, rad, N, N m, kg, W, J.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from . import contacts as _contacts_module
from .cache_stamp import dependency_stamp
from .contacts import (
    F_DISS_DAMPING,
    F_DISS_LUBRICANT,
    F_GROOVE_MZ,
    N_STATICS,
    R_FORCE,
    R_GROOVE_FORCE,
    R_MOMENT,
    contacts_kinetics_kernel,
    contacts_statics_kernel,
)
from .solver_settings import (
    HELIX_NEWTON_STEPS,
    JACOBIAN_REFRESH_RATIO,
    PREDICTOR_ORDER,
    STEP_BACKTRACKS,
    STEP_NEWTON_MAX,
    STEP_TOLERANCE,
    VELOCITY_STEP,
)

SOLVER_CONSTANTS = (
    HELIX_NEWTON_STEPS,
    JACOBIAN_REFRESH_RATIO,
    PREDICTOR_ORDER,
    STEP_BACKTRACKS,
    STEP_NEWTON_MAX,
    STEP_TOLERANCE,
    VELOCITY_STEP,
)

# ----------------------------------------------------------------------------- layouts
# Body state (8,): time [s], screw angle [rad], screw speed [rad/s], controller integral [rad],
# nut positions (2) [m], nut velocities (2) [m/s].
B_TIME, B_ANGLE, B_SPEED, B_INTEGRAL, B_NUT_POS, B_NUT_VEL = 0, 1, 2, 3, 4, 6
N_BODY = 8
# Constants (N_CONST,): step [s], sphere mass [kg] and inertia [kg m^2], gravity vector (3)
# [m/s^2] and magnitude [m/s^2], screw inertia [kg m^2], nut mass [kg], nut weight along -z
# [N] (0 for a horizontal screw), PI gains k_p [N m s/rad], k_i [N m/rad], ball radius [m],
# pitch radius [m], lead / (2 pi) [m], sin and cos of the helix angle, initial nut offsets (2)
# [m], 1 when the positions are implicit (contact actions with the sphere centres at
# x_n + dt v_{n+1} and the screw at phi_n + dt Omega_{n+1}) else 0 (at x_n, phi_n) [-].
(
    K_DT,
    K_MASS,
    K_INERTIA,
    K_GX,
    K_GY,
    K_GZ,
    K_G,
    K_SCREW_INERTIA,
    K_NUT_MASS,
    K_WEIGHT,
    K_KP,
    K_KI,
    K_BALL_RADIUS,
    K_PITCH_RADIUS,
    K_LEAD_RATE,
    K_SIN_HELIX,
    K_COS_HELIX,
    K_NUT_OFFSET0,
) = range(18)
K_IMPLICIT = 19
N_CONST = 20
# Jacobian bookkeeping (3,) int64: valid (0/1), age [steps], refresh interval [steps].
J_VALID, J_AGE, J_INTERVAL = 0, 1, 2
# Step statistics (S_COUNT,): motor torque at the end of the step [N m], moment of the spheres
# on the screw [N m], axial force on each nut (2) [N], total dissipation [W], final scaled
# residual [-], 1 when not converged, contact evaluations made [-], Jacobian evaluations made
# [-], Newton iterations made [-], dissipation per mechanism (7, models.base.DISSIPATION_KEYS
# order) [W], dissipation of each nut's spheres (2) [W].
(
    S_MOTOR,
    S_SCREW_TORQUE,
    S_NUT_FORCE,
    S_DISSIPATION,
    S_RESIDUAL,
    S_UNCONVERGED,
    S_EVALS,
    S_JACOBIANS,
    S_ITERATIONS,
    S_MECHANISMS,
    S_NUT_DISSIPATION,
) = (0, 1, 2, 4, 5, 6, 7, 8, 9, 10, 17)
N_MECHANISMS = F_DISS_DAMPING + 1 - F_DISS_LUBRICANT
S_COUNT = 19
# Rows of a sphere's stacked actions (8,): force (3) [N], moment (3) [N m], its moment on the
# screw about z [N m], its axial force on its nut [N].
N_STACK = 8


#: frozen into the cached code by :func:`compiled_stamp`; compared at first use
DEPENDENCY_STAMP = dependency_stamp((_contacts_module,), SOLVER_CONSTANTS)


@njit(cache=True)
def compiled_stamp():
    """DEPENDENCY_STAMP as it was when the cached machine code was compiled."""
    return DEPENDENCY_STAMP


@njit(cache=True)
def frozen_constants():
    """The solver constants as the cached machine code sees them (tested against dynamic.py)."""
    return (
        HELIX_NEWTON_STEPS,
        JACOBIAN_REFRESH_RATIO,
        PREDICTOR_ORDER,
        STEP_BACKTRACKS,
        STEP_NEWTON_MAX,
        STEP_TOLERANCE,
        VELOCITY_STEP,
    )


# ----------------------------------------------------------------------------- helpers
@njit(cache=True)
def _lu_solve(a, rhs):
    """Solve a x = rhs in place (rhs becomes x) by LU with partial pivoting; a is overwritten.

    a (n, n), rhs (n, m). Returns False when a pivot is exactly zero (singular).
    """
    n = a.shape[0]
    m = rhs.shape[1]
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
            for c in range(m):
                rhs[k, c], rhs[pivot, c] = rhs[pivot, c], rhs[k, c]
        if a[k, k] == 0.0:
            return False
        inv = 1.0 / a[k, k]
        for r in range(k + 1, n):
            factor = a[r, k] * inv
            if factor != 0.0:
                for c in range(k + 1, n):
                    a[r, c] -= factor * a[k, c]
                for c in range(m):
                    rhs[r, c] -= factor * rhs[k, c]
    for c in range(m):
        for r in range(n - 1, -1, -1):
            total = rhs[r, c]
            for q in range(r + 1, n):
                total -= a[r, q] * rhs[q, c]
            rhs[r, c] = total / a[r, r]
    return True


@njit(cache=True)
def _locate(pos, screw_angle, theta_start, c, theta, frames, nb):
    """Helix parameter, Frenet frames and (n, b) offsets of every sphere (Eq. 4, DynamicModel.
    _locate): ``theta``, ``frames`` (B, 3, 3) rows t, n, b in screw coordinates, ``nb`` (B, 2)."""
    r_m = c[K_PITCH_RADIUS]
    lead = c[K_LEAD_RATE]
    sl = c[K_SIN_HELIX]
    cl = c[K_COS_HELIX]
    ca = math.cos(screw_angle)
    sa = math.sin(screw_angle)
    for i in range(pos.shape[0]):
        x = ca * pos[i, 0] + sa * pos[i, 1]
        y = -sa * pos[i, 0] + ca * pos[i, 1]
        z = pos[i, 2]
        th = theta_start[i]
        for _ in range(HELIX_NEWTON_STEPS):
            ct = math.cos(th)
            st = math.sin(th)
            rx = x - r_m * ct
            ry = y - r_m * st
            rz = z - lead * th
            tx = -r_m * st
            ty = r_m * ct
            f = rx * tx + ry * ty + rz * lead
            df = -(tx * tx + ty * ty + lead * lead) + (rx * (-r_m * ct) + ry * (-r_m * st))
            th = th - f / df
        theta[i] = th
        ct = math.cos(th)
        st = math.sin(th)
        frames[i, 0, 0] = -st * cl
        frames[i, 0, 1] = ct * cl
        frames[i, 0, 2] = sl
        frames[i, 1, 0] = -ct
        frames[i, 1, 1] = -st
        frames[i, 1, 2] = 0.0
        frames[i, 2, 0] = st * sl
        frames[i, 2, 1] = -ct * sl
        frames[i, 2, 2] = cl
        rx = x - r_m * ct
        ry = y - r_m * st
        rz = z - lead * th
        nb[i, 0] = rx * frames[i, 1, 0] + ry * frames[i, 1, 1] + rz * frames[i, 1, 2]
        nb[i, 1] = rx * frames[i, 2, 0] + ry * frames[i, 2, 1] + rz * frames[i, 2, 2]


@njit(cache=True)
def _approach_offsets(theta, screw_angle, sphere_offset, spalls, offsets):
    """Defect offsets of every contact's approach [m] (Faults.approach_offsets).

    sphere_offset (B, 4): radius changes of defective spheres; spalls (S, 4): half-groove
    column, centre [rad], width [rad], depth [m].
    """
    for i in range(theta.shape[0]):
        for j in range(4):
            offsets[i, j] = sphere_offset[i, j]
    for s in range(spalls.shape[0]):
        column = int(spalls[s, 0])
        for i in range(theta.shape[0]):
            th = theta[i] + (screw_angle if column >= 2 else 0.0)
            x = (th - spalls[s, 1]) / spalls[s, 2]
            if abs(x) < 0.5:
                cosine = math.cos(math.pi * x)
                offsets[i, column] -= spalls[s, 3] * (cosine * cosine)


@njit(cache=True)
def _statics(body, nb, offsets, ball_nut, c, p, statics):
    """The velocity-independent part of every contact at the step's positions, written to
    ``statics`` (B, 4, N_STATICS; contacts_statics_kernel): the sphere offsets ``nb`` (B, 2)
    [m], the nut groove's b-offset from the nut positions and the screw angle in ``body``, the
    defect offsets ``offsets`` (B, 4) [m]. Kept for every evaluation of the step."""
    count = nb.shape[0]
    angle = body[B_ANGLE]
    nut_offset = np.empty(count)
    for i in range(count):
        k = ball_nut[i]
        shift = body[B_NUT_POS + k] + c[K_LEAD_RATE] * angle
        nut_offset[i] = c[K_NUT_OFFSET0 + k] + shift * c[K_COS_HELIX]
    contacts_statics_kernel(nb, nut_offset, offsets, p, statics)


@njit(cache=True)
def _actions(vel, omega, nut_vel, speed, pos, body, frames, nb, statics, ball_nut, c, p, stacked):
    """Contact actions of every sphere at the given velocities (DynamicModel.contact_actions),
    from the contacts' ``statics`` at the step's positions (``_statics``).

    Writes ``stacked`` (B, 8): force and moment on the sphere (world frame), its moment on the
    screw about z and its axial force on its nut; returns the kernel's (active, buffer).
    """
    count = pos.shape[0]
    angle = body[B_ANGLE]
    ca = math.cos(angle)
    sa = math.sin(angle)
    v_frenet = np.empty((count, 3))
    w_frenet = np.empty((count, 3))
    slide = np.empty(count)
    lead = c[K_LEAD_RATE]
    for i in range(count):
        # Velocity relative to the rotating screw, in screw coordinates, then Frenet.
        wx = vel[i, 0] - speed * (-pos[i, 1])
        wy = vel[i, 1] - speed * pos[i, 0]
        wz = vel[i, 2] - speed * 0.0
        vx = ca * wx + sa * wy
        vy = -sa * wx + ca * wy
        vz = wz
        ox = ca * omega[i, 0] + sa * omega[i, 1]
        oy = -sa * omega[i, 0] + ca * omega[i, 1]
        oz = omega[i, 2] - speed
        for r in range(3):
            v_frenet[i, r] = frames[i, r, 0] * vx + frames[i, r, 1] * vy + frames[i, r, 2] * vz
            w_frenet[i, r] = frames[i, r, 0] * ox + frames[i, r, 1] * oy + frames[i, r, 2] * oz
        slide[i] = nut_vel[ball_nut[i]] + speed * lead
    active, out = contacts_kinetics_kernel(statics, nb, w_frenet, v_frenet, slide, p, speed)
    for i in range(count):
        for q in range(2):
            row = R_FORCE if q == 0 else R_MOMENT
            # Frenet -> screw coordinates (frames^T), then screw -> world.
            sx = 0.0
            sy = 0.0
            sz = 0.0
            for r in range(3):
                value = out[row + r, i, 0]
                sx += frames[i, r, 0] * value
                sy += frames[i, r, 1] * value
                sz += frames[i, r, 2] * value
            stacked[i, 3 * q + 0] = ca * sx - sa * sy
            stacked[i, 3 * q + 1] = sa * sx + ca * sy
            stacked[i, 3 * q + 2] = sz
        stacked[i, 6] = out[F_GROOVE_MZ, i, 0] + out[F_GROOVE_MZ, i, 1]
        on_t = out[R_GROOVE_FORCE, i, 2] + out[R_GROOVE_FORCE, i, 3]
        on_b = out[R_GROOVE_FORCE + 2, i, 2] + out[R_GROOVE_FORCE + 2, i, 3]
        stacked[i, 7] = on_t * c[K_SIN_HELIX] + on_b * c[K_COS_HELIX]
    return active, out


@njit(cache=True)
def _place(vel, speed, start, ball_nut, c, p, placed):
    """The spheres and the screw where the step's end velocities ``vel`` (B, 3) [m/s] and
    ``speed`` [rad/s] put them (implicit positions, DynamicModel._trial): centres x_n + dt v,
    screw angle phi_n + dt Omega, the spheres located on the helix, their defect offsets and
    the contact statics, written to ``placed``; the nut positions stay those of the step's
    start. start = (pos, body, theta, sphere_offset, spalls) of the step;
    placed = (pos, body, theta, frames, nb, statics)."""
    pos, body, theta, sphere_offset, spalls = start
    at_pos, at_body, at_theta, frames, nb, statics = placed
    dt = c[K_DT]
    for i in range(pos.shape[0]):
        for k in range(3):
            at_pos[i, k] = pos[i, k] + dt * vel[i, k]
    at_body[:] = body
    at_body[B_ANGLE] = body[B_ANGLE] + dt * speed
    _locate(at_pos, at_body[B_ANGLE], theta, c, at_theta, frames, nb)
    offsets = np.empty((pos.shape[0], 4))
    _approach_offsets(at_theta, at_body[B_ANGLE], sphere_offset, spalls, offsets)
    _statics(at_body, nb, offsets, ball_nut, c, p, statics)


@njit(cache=True)
def _evaluate(vel, omega, nut_vel, speed, start, placed, ball_nut, c, p, stacked):
    """Contact actions at the given velocities (``_actions``, ``stacked`` written): at the
    step's positions (semi-implicit: ``placed`` holds them and their statics), or, with
    implicit sphere positions (c[K_IMPLICIT] = 1), with the spheres where these velocities
    put them (``_place`` first)."""
    if c[K_IMPLICIT] != 0.0:
        _place(vel, speed, start, ball_nut, c, p, placed)
    at_pos, at_body, _, frames, nb, statics = placed
    return _actions(
        vel, omega, nut_vel, speed, at_pos, at_body, frames, nb, statics, ball_nut, c, p, stacked
    )


@njit(cache=True)
def _jacobians(vel, omega, nut_vel, speed, base, start, placed, ball_nut, c, p, own, shared):
    """Forward-difference velocity Jacobians (DynamicModel._jacobians): ``own`` (B, 8, 6) with
    respect to each sphere's velocity and angular velocity, ``shared`` (B, 8, 3) with respect to
    the screw speed and its nut's velocity. ``base`` (B, 8): the actions at these velocities.
    With implicit positions a perturbed sphere velocity or screw speed also moves the sphere or
    the screw by dt times the perturbation (``_evaluate``): the columns are the total
    derivatives d f(x_n + dt v, phi_n + dt Omega, u) / du."""
    count = vel.shape[0]
    bumped = np.empty((count, N_STACK))
    v = np.empty((count, 3))
    w = np.empty((count, 3))
    r_b = c[K_BALL_RADIUS]
    for j in range(6):
        v[:, :] = vel
        w[:, :] = omega
        h = VELOCITY_STEP if j < 3 else VELOCITY_STEP / r_b
        for i in range(count):
            if j < 3:
                v[i, j] += h
            else:
                w[i, j - 3] += h
        _evaluate(v, w, nut_vel, speed, start, placed, ball_nut, c, p, bumped)
        for i in range(count):
            for r in range(N_STACK):
                own[i, r, j] = (bumped[i, r] - base[i, r]) / h
    h_screw = VELOCITY_STEP / c[K_PITCH_RADIUS]
    _evaluate(vel, omega, nut_vel, speed + h_screw, start, placed, ball_nut, c, p, bumped)
    for i in range(count):
        for r in range(N_STACK):
            shared[i, r, 0] = (bumped[i, r] - base[i, r]) / h_screw
    nut_bumped = np.empty(2)
    nut_bumped[0] = nut_vel[0] + VELOCITY_STEP
    nut_bumped[1] = nut_vel[1] + VELOCITY_STEP
    _evaluate(vel, omega, nut_bumped, speed, start, placed, ball_nut, c, p, bumped)
    for i in range(count):
        k = ball_nut[i]
        for r in range(N_STACK):
            column = (bumped[i, r] - base[i, r]) / VELOCITY_STEP
            shared[i, r, 1 + k] = column
            shared[i, r, 2 - k] = 0.0


@njit(cache=True)
def _residual(
    stacked, u, u0, shared_v, shared0, ball_nut, jammed, body, commands, c, r_ball, r_shared
):
    """Backward-Euler residuals of the sphere rows (B, 6) and shared rows (3,), written in place;
    returns their scaled maximum (the reference's ``residual``)."""
    count = u.shape[0]
    dt = c[K_DT]
    mass = c[K_MASS]
    inertia = c[K_INERTIA]
    kp = c[K_KP]
    ki = c[K_KI]
    error = commands[0] - shared_v[0]
    motor = kp * error + ki * (body[B_INTEGRAL] + dt * error)
    g = np.empty(3)
    g[0] = motor
    g[1] = commands[1] - c[K_WEIGHT]
    g[2] = -commands[1] - c[K_WEIGHT]
    force_max = 0.0
    for i in range(count):
        g[0] += stacked[i, 6]
        g[1 + ball_nut[i]] += stacked[i, 7]
        for k in range(3):
            f = stacked[i, k] + mass * c[K_GX + k]
            force_max = max(force_max, abs(f))
            r_ball[i, k] = dt * f - mass * (u[i, k] - u0[i, k])
            r_ball[i, 3 + k] = dt * stacked[i, 3 + k] - inertia * (u[i, 3 + k] - u0[i, 3 + k])
            if jammed[i]:  # blocked rotation: omega = 0 is the equation
                r_ball[i, 3 + k] = 0.0
    force_scale = force_max + mass * c[K_G]
    scale_f = dt * force_scale
    scale_m = dt * (force_scale * c[K_BALL_RADIUS])
    worst_ball = 0.0
    for i in range(count):
        for k in range(6):
            value = abs(r_ball[i, k]) / (scale_f if k < 3 else scale_m)
            if value > worst_ball or math.isnan(value):  # NaN propagates, as np.max
                worst_ball = value
                if math.isnan(value):
                    return value
    masses = (c[K_SCREW_INERTIA], c[K_NUT_MASS], c[K_NUT_MASS])
    floors = (1e-6, 1e-3, 1e-3)
    worst_shared = 0.0
    for k in range(3):
        r_shared[k] = dt * g[k] - masses[k] * (shared_v[k] - shared0[k])
        worst_shared = max(worst_shared, abs(r_shared[k]) / (dt * (abs(g[k]) + floors[k])))
    return worst_shared if worst_shared > worst_ball else worst_ball


@njit(cache=True)
def _correction(own, shared_jac, r_ball, r_shared, ball_nut, jammed, c, du, d_shared):
    """Newton correction of the backward-Euler equations (DynamicModel._correction): sphere
    blocks eliminated, 3 x 3 Schur complement on the screw and nut rows. Returns False when a
    block is exactly singular."""
    count = r_ball.shape[0]
    dt = c[K_DT]
    mass = c[K_MASS]
    inertia = c[K_INERTIA]
    block = np.empty((6, 6))
    rhs = np.empty((6, 4))
    solved = np.empty((count, 6, 4))
    lhs = np.zeros((3, 3))
    rhs_shared = np.empty((3, 1))
    for k in range(3):
        rhs_shared[k, 0] = 0.0
    ok = True
    for i in range(count):
        for r in range(6):
            for q in range(6):
                diag = (mass if r < 3 else inertia) if r == q else 0.0
                block[r, q] = diag - dt * own[i, r, q]
                if jammed[i] and r >= 3:  # blocked rotation: I dw = 0
                    block[r, q] = inertia if r == q else 0.0
            rhs[r, 0] = r_ball[i, r]
            for q in range(3):
                rhs[r, 1 + q] = dt * shared_jac[i, r, q]
            if jammed[i] and r >= 3:
                for q in range(4):
                    rhs[r, q] = 0.0
        ok = _lu_solve(block, rhs) and ok
        solved[i] = rhs
        k = ball_nut[i]
        for row in range(2):  # screw share -> row 0, nut share -> row 1 + k
            target = 0 if row == 0 else 1 + k
            cp = 0.0
            for q in range(6):
                cp += own[i, 6 + row, q] * rhs[q, 0]
            rhs_shared[target, 0] += cp
            for col in range(3):
                cq = 0.0
                for q in range(6):
                    cq += own[i, 6 + row, q] * rhs[q, 1 + col]
                lhs[target, col] += cq + shared_jac[i, 6 + row, col]
    masses = (c[K_SCREW_INERTIA], c[K_NUT_MASS], c[K_NUT_MASS])
    for r in range(3):
        for q in range(3):
            lhs[r, q] = (masses[r] if r == q else 0.0) - dt * lhs[r, q]
        rhs_shared[r, 0] = r_shared[r] + dt * rhs_shared[r, 0]
    lhs[0, 0] += dt * (c[K_KP] + c[K_KI] * dt)
    ok = _lu_solve(lhs, rhs_shared) and ok
    for k in range(3):
        d_shared[k] = rhs_shared[k, 0]
    for i in range(count):
        for r in range(6):
            du[i, r] = solved[i, r, 0] + (
                solved[i, r, 1] * d_shared[0]
                + solved[i, r, 2] * d_shared[1]
                + solved[i, r, 3] * d_shared[2]
            )
    return ok


#: Extrapolation of the velocities from the starts of the last steps, u_n, u_{n-1}, ...: the
#: coefficients of the polynomial predictor of each order (0: u_n; 3: cubic).
PREDICTOR_COEFFICIENTS = ((1.0, 0.0, 0.0, 0.0), (2.0, -1.0, 0.0, 0.0), (3.0, -3.0, 1.0, 0.0),
                          (4.0, -6.0, 4.0, -1.0))  # fmt: skip
# Predictor bookkeeping (3,) float64: the time the next step starts at if it continues the last
# one [s] (NaN: none), the number of earlier starts kept [-], the order to use [-].
H_NEXT_TIME, H_COUNT, H_ORDER = 0, 1, 2


@njit(cache=True)
def _extrapolate(order, row, column, now, history):
    """Velocity component extrapolated at ``order`` from ``now`` (u_n) and history[0..order-1]
    (u_{n-1}, ...) at (row, column)."""
    coefficients = PREDICTOR_COEFFICIENTS[order]
    value = coefficients[0] * now
    for j in range(order):
        value += coefficients[j + 1] * history[j, row, column]
    return value


@njit(cache=True)
def _predict(u0, shared0, time, jammed, history, meta, u, shared):
    """Newton's first guess (DynamicModel._predict): u_n extrapolated at the order meta[H_ORDER]
    from the starts of the last steps when the step continues the last one (``time`` [s] is
    meta[H_NEXT_TIME]); else ``u``, ``shared`` are left as given (u_n). A jammed sphere's
    rotation stays zero. Returns True when it extrapolated.

    history (PREDICTOR_ORDER, B + 1, 6): u_{n-1}, u_{n-2}, ... (sphere rows; row B holds the
    screw speed and nut velocities in columns 0-2); meta (3,): layout H_*.
    """
    count = u0.shape[0]
    order = int(meta[H_ORDER])
    if meta[H_NEXT_TIME] != time or order == 0:
        return False
    for i in range(count):
        for k in range(6):
            u[i, k] = _extrapolate(order, i, k, u0[i, k], history)
            if jammed[i] and k >= 3:
                u[i, k] = 0.0
    for k in range(3):
        shared[k] = _extrapolate(order, count, k, shared0[k], history)
    return True


@njit(cache=True)
def _remember(u0, shared0, u, shared, time, c, history, meta):
    """After a step from ``time`` [s]: the order for the next step is the one whose prediction
    came closest to the converged velocities ``u``, ``shared`` (largest difference over all
    components, angular velocities times the ball radius, screw speed times the pitch radius,
    in m/s; ties to the lower order); u0, shared0 join the history (DynamicModel._remember)."""
    count = u0.shape[0]
    depth = history.shape[0]
    kept = int(meta[H_COUNT]) if meta[H_NEXT_TIME] == time else 0
    best = 0
    best_error = math.inf
    for order in range(min(kept, depth) + 1):
        error = 0.0
        for i in range(count):
            for k in range(6):
                weight = 1.0 if k < 3 else c[K_BALL_RADIUS]
                guess = _extrapolate(order, i, k, u0[i, k], history)
                error = max(error, weight * abs(guess - u[i, k]))
        for k in range(3):
            weight = c[K_PITCH_RADIUS] if k == 0 else 1.0
            guess = _extrapolate(order, count, k, shared0[k], history)
            error = max(error, weight * abs(guess - shared[k]))
        if error < best_error:
            best = order
            best_error = error
    for j in range(depth - 1, 0, -1):
        history[j, :, :] = history[j - 1]
    for i in range(count):
        for k in range(6):
            history[0, i, k] = u0[i, k]
    for k in range(3):
        history[0, count, k] = shared0[k]
    meta[H_NEXT_TIME] = time + c[K_DT]
    meta[H_COUNT] = min(kept + 1, depth)
    meta[H_ORDER] = best


# ----------------------------------------------------------------------------- the step
@njit(cache=True, error_model="numpy")
def step_kernel(
    pos,
    vel,
    omega,
    theta,
    body,
    commands,
    ball_nut,
    c,
    p,
    sphere_offset,
    spalls,
    jammed,
    jac_own,
    jac_shared,
    jac_active,
    jac_meta,
    history,
    history_meta,
    out_pos,
    out_vel,
    out_omega,
    out_theta,
    out_body,
    stats,
):
    """One backward-Euler step of all bodies, solved by Newton (DynamicModel._step).

    Args:
        pos, vel, omega: (B, 3) sphere centre positions [m], velocities [m/s], angular
            velocities [rad/s] (world frame); theta (B,) helix parameters [rad] (start of the
            helix search).
        body: (8,) body state (layout B_*); commands: (2,) speed reference [rad/s], preload [N].
        ball_nut: (B,) int64 nut of each sphere; c: constants (layout K_*); p: the scalar
            parameters of contacts_kernel (``scene_arrays``) as float64.
        sphere_offset: (B, 4) [m] and spalls (S, 4): defects (see ``_approach_offsets``).
        jammed: (B,) bool, spheres whose rotation is blocked (held at zero).
        jac_own, jac_shared, jac_active, jac_meta: the Jacobian kept between steps (updated).
        history, history_meta: the velocities at the starts of the last steps and the
            predictor's bookkeeping (see ``_predict``), kept between steps (updated).
        out_pos, out_vel, out_omega, out_theta, out_body: the new state (written).
        stats: (S_COUNT,) step statistics (layout S_*, written).

    Returns:
        active (B, 4) and the contact kernel's buffer at the converged velocities.
    """
    count = pos.shape[0]
    dt = c[K_DT]
    frames = np.empty((count, 3, 3))
    nb = np.empty((count, 2))
    statics = np.empty((count, 4, N_STATICS))
    start = (pos, body, theta, sphere_offset, spalls)
    placed = (pos.copy(), body.copy(), out_theta, frames, nb, statics)
    if c[K_IMPLICIT] == 0.0:  # semi-implicit: the step's positions, located once
        _locate(pos, body[B_ANGLE], theta, c, out_theta, frames, nb)
        offsets = np.empty((count, 4))
        _approach_offsets(out_theta, body[B_ANGLE], sphere_offset, spalls, offsets)
        _statics(body, nb, offsets, ball_nut, c, p, statics)

    u0 = np.empty((count, 6))
    for i in range(count):
        for k in range(3):
            u0[i, k] = vel[i, k]
            u0[i, 3 + k] = 0.0 if jammed[i] else omega[i, k]
    shared0 = np.empty(3)
    shared0[0] = body[B_SPEED]
    shared0[1] = body[B_NUT_VEL]
    shared0[2] = body[B_NUT_VEL + 1]
    u = np.empty((count, 6))
    sv = np.empty(3)
    v_start = np.empty((count, 3))
    w_start = np.empty((count, 3))
    stacked = np.empty((count, N_STACK))
    r_ball = np.empty((count, 6))
    r_shared = np.empty(3)
    du = np.empty((count, 6))
    d_shared = np.empty(3)
    u_try = np.empty((count, 6))
    sv_try = np.empty(3)
    v_try = np.empty((count, 3))
    w_try = np.empty((count, 3))
    stacked_try = np.empty((count, N_STACK))
    rb = np.empty((count, 6))
    rs = np.empty(3)
    evals = 0
    jacobians = 0
    iterations = 0
    worst = 0.0
    unconverged = False
    # A step that does not converge from the predicted guess is solved again from u_n with a
    # fresh Jacobian (the guess must not cost convergence).
    for attempt in range(2):
        u[:, :] = u0
        sv[:] = shared0
        predicted = False
        if attempt == 0:
            predicted = _predict(u0, shared0, body[B_TIME], jammed, history, history_meta, u, sv)
        for i in range(count):
            for k in range(3):
                v_start[i, k] = u[i, k]
                w_start[i, k] = u[i, 3 + k]
        active, out = _evaluate(
            v_start, w_start, sv[1:], sv[0], start, placed, ball_nut, c, p, stacked
        )
        evals += 1
        stale = attempt == 1 or jac_meta[J_VALID] == 0 or jac_meta[J_AGE] >= jac_meta[J_INTERVAL]
        for i in range(count):
            for j in range(4):
                if active[i, j] != jac_active[i, j]:
                    stale = True
        if attempt == 0:
            jac_meta[J_AGE] += 1
        worst = _residual(
            stacked, u, u0, sv, shared0, ball_nut, jammed, body, commands, c, r_ball, r_shared
        )
        converged_loop = False
        previous = worst
        for iteration in range(STEP_NEWTON_MAX):
            if worst < STEP_TOLERANCE:
                converged_loop = True
                break
            if iteration == 0 and stale:  # refreshed when a correction needs it, at the start
                _jacobians(
                    v_start, w_start, sv[1:], sv[0], stacked, start, placed, ball_nut, c, p,
                    jac_own, jac_shared,
                )  # fmt: skip
                evals += 8
                jacobians += 1
                jac_active[:, :] = active
                jac_meta[J_VALID] = 1
                jac_meta[J_AGE] = 1
            if iteration > 0 and not worst < JACOBIAN_REFRESH_RATIO * previous:
                for i in range(count):
                    for k in range(3):
                        v_try[i, k] = u[i, k]
                        w_try[i, k] = u[i, 3 + k]
                _jacobians(
                    v_try, w_try, sv[1:], sv[0], stacked, start, placed, ball_nut, c, p, jac_own,
                    jac_shared,
                )  # fmt: skip
                evals += 8
                jacobians += 1
                jac_active[:, :] = active
                jac_meta[J_AGE] = 0
            _correction(jac_own, jac_shared, r_ball, r_shared, ball_nut, jammed, c, du, d_shared)
            iterations += 1
            step = 1.0
            w = 0.0
            for _ in range(STEP_BACKTRACKS + 1):
                for i in range(count):
                    for k in range(6):
                        u_try[i, k] = u[i, k] + step * du[i, k]
                    for k in range(3):
                        v_try[i, k] = u_try[i, k]
                        w_try[i, k] = u_try[i, 3 + k]
                for k in range(3):
                    sv_try[k] = sv[k] + step * d_shared[k]
                active_try, out_try = _evaluate(
                    v_try, w_try, sv_try[1:], sv_try[0], start, placed, ball_nut, c, p,
                    stacked_try,
                )  # fmt: skip
                evals += 1
                w = _residual(
                    stacked_try, u_try, u0, sv_try, shared0, ball_nut, jammed, body, commands, c,
                    rb, rs,
                )  # fmt: skip
                if w < worst or iteration == 0:
                    break
                step *= 0.5
            previous = worst
            u[:, :] = u_try
            sv[:] = sv_try
            active = active_try
            out = out_try
            stacked[:, :] = stacked_try
            r_ball[:, :] = rb
            r_shared[:] = rs
            worst = w
        unconverged = (not converged_loop) and worst >= STEP_TOLERANCE
        if not unconverged or not predicted:
            break
    _remember(u0, shared0, u, sv, body[B_TIME], c, history, history_meta)

    kp = c[K_KP]
    ki = c[K_KI]
    new_error = commands[0] - sv[0]
    integral = body[B_INTEGRAL] + dt * new_error
    out_body[B_TIME] = body[B_TIME] + dt
    out_body[B_ANGLE] = body[B_ANGLE] + dt * sv[0]
    out_body[B_SPEED] = sv[0]
    out_body[B_INTEGRAL] = integral
    for k in range(2):
        out_body[B_NUT_POS + k] = body[B_NUT_POS + k] + dt * sv[1 + k]
        out_body[B_NUT_VEL + k] = sv[1 + k]
    for i in range(count):
        for k in range(3):
            out_pos[i, k] = pos[i, k] + dt * u[i, k]
            out_vel[i, k] = u[i, k]
            out_omega[i, k] = u[i, 3 + k]

    stats[S_MOTOR] = kp * new_error + ki * integral
    screw_torque = 0.0
    nut_force = np.zeros(2)
    for i in range(count):
        screw_torque += stacked[i, 6]
        nut_force[ball_nut[i]] += stacked[i, 7]
    stats[S_SCREW_TORQUE] = screw_torque
    stats[S_NUT_FORCE] = nut_force[0]
    stats[S_NUT_FORCE + 1] = nut_force[1]
    dissipation = 0.0
    stats[S_NUT_DISSIPATION] = 0.0
    stats[S_NUT_DISSIPATION + 1] = 0.0
    for row in range(F_DISS_LUBRICANT, F_DISS_DAMPING + 1):
        mechanism = 0.0
        for i in range(count):
            ball = 0.0
            for j in range(4):
                ball += out[row, i, j]
            mechanism += ball
            stats[S_NUT_DISSIPATION + ball_nut[i]] += ball
        stats[S_MECHANISMS + row - F_DISS_LUBRICANT] = mechanism
        dissipation += mechanism
    stats[S_DISSIPATION] = dissipation
    stats[S_RESIDUAL] = worst
    stats[S_UNCONVERGED] = 1.0 if unconverged else 0.0
    stats[S_EVALS] = evals
    stats[S_JACOBIANS] = jacobians
    stats[S_ITERATIONS] = iterations
    return active, out


# ----------------------------------------------------------------------------- time loop
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
    integrals and the sums over the averaging window (steps >= ``window_first``).

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
    """Recompile this module's kernels once when their cache predates contacts.py or the
    constants (see the module docstring). Returns True when it recompiled."""
    global _checked_cache
    if _checked_cache:
        return False
    stale = bool(compiled_stamp() != DEPENDENCY_STAMP)
    if stale:
        for dispatcher in (
            _statics,
            _lu_solve,
            _locate,
            _approach_offsets,
            _actions,
            _place,
            _evaluate,
            _jacobians,
            _residual,
            _correction,
            _extrapolate,
            _predict,
            _remember,
            step_kernel,
            _account,
            run_steps,
            frozen_constants,
            compiled_stamp,
        ):
            dispatcher.recompile()
    _checked_cache = True
    return stale
