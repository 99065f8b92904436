"""Compiled time step of the dynamic model (numba): the twin of ``DynamicModel._step``.

:func:`step_kernel` performs one step of :meth:`ballscrew_twin.models.dynamic.DynamicModel._step`
operation for operation, with the contact laws of
:mod:`ballscrew_twin.kernels.contacts` and no Python in the step:

- the spheres are located on the helix once (Newton on (r - B(theta)) . dB/dtheta = 0, Eq. 4;
  ``_locate``), the defect offsets of the approach follow (``_approach_offsets``, as
  :meth:`Faults.approach_offsets`);
- the array layouts are those of :mod:`.dynamic_layouts`;
- the velocity-independent part of the contact laws once per step (``_statics``:
  :func:`~ballscrew_twin.kernels.contacts.contacts_statics_kernel`, geometry, Hertz ellipse and
  stiffness, contact normal and point, pressure viscosity; the positions do not move within a
  step);
- contact actions at given velocities (``_actions``): velocities relative to the screw in each
  sphere's Frenet frame, the rest of the contact laws from the step's statics
  (:func:`~ballscrew_twin.kernels.contacts.contacts_kinetics_kernel`, bit for bit
  ``contacts_kernel``'s dynamic path), forces and moments back to the world frame, each
  sphere's moment on the screw and axial force on its nut;
- Newton's first guess (``predict``, ``remember``): the velocities extrapolated from the
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

:mod:`ballscrew_twin.kernels.dynamic_run` loops :func:`step_kernel` over the steps of a run.

numba freezes the solver constants (:mod:`ballscrew_twin.kernels.solver_settings`) and the
machine code of ``contacts_kernel`` and of the predictor (:mod:`.dynamic_predictor`) into the
cache, which is invalidated only by a change of this file; :data:`DEPENDENCY_STAMP` (a hash of
contacts.py, dynamic_layouts.py, dynamic_predictor.py and the constants) is frozen with them and
:func:`ensure_fresh_cache` recompiles once when it is stale (as kernels/steady_solver.py).
Everything is SI: m, s, rad, N, N m, kg, W, J.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from . import contacts as _contacts_module
from . import dynamic_layouts as _layouts_module
from . import dynamic_predictor as _predictor_module
from .cache_stamp import dependency_stamp
from .contact_layout import (
    F_DISS_DAMPING,
    F_DISS_LUBRICANT,
    F_GROOVE_MZ,
    N_STATICS,
    R_FORCE,
    R_GROOVE_FORCE,
    R_MOMENT,
)
from .contacts import contacts_kinetics_kernel, contacts_statics_kernel
from .dynamic_layouts import (
    B_ANGLE,
    B_INTEGRAL,
    B_NUT_POS,
    B_NUT_VEL,
    B_SPEED,
    B_TIME,
    J_AGE,
    J_INTERVAL,
    J_VALID,
    K_BALL_RADIUS,
    K_COS_HELIX,
    K_DT,
    K_G,
    K_GX,
    K_IMPLICIT,
    K_INERTIA,
    K_KI,
    K_KP,
    K_LEAD_RATE,
    K_MASS,
    K_NUT_MASS,
    K_NUT_OFFSET0,
    K_PITCH_RADIUS,
    K_SCREW_INERTIA,
    K_SIN_HELIX,
    K_WEIGHT,
    N_STACK,
    S_DISSIPATION,
    S_EVALS,
    S_ITERATIONS,
    S_JACOBIANS,
    S_MECHANISMS,
    S_MOTOR,
    S_NUT_DISSIPATION,
    S_NUT_FORCE,
    S_RESIDUAL,
    S_SCREW_TORQUE,
    S_UNCONVERGED,
)
from .dynamic_predictor import extrapolate, predict, remember
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

#: frozen into the cached code by :func:`compiled_stamp`; compared at first use
DEPENDENCY_STAMP = dependency_stamp(
    (_contacts_module, _layouts_module, _predictor_module), SOLVER_CONSTANTS
)


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
            predictor's bookkeeping (see ``predict``), kept between steps (updated).
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
            predicted = predict(u0, shared0, body[B_TIME], jammed, history, history_meta, u, sv)
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
    remember(u0, shared0, u, sv, body[B_TIME], c, history, history_meta)

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


# ----------------------------------------------------------------------------- cache
_checked_cache = False


def ensure_fresh_cache() -> bool:
    """Recompile this module's kernels (and the predictor's) once when their cache predates
    contacts.py, the layouts, the predictor or the constants (see the module docstring).
    Returns True when it recompiled."""
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
            extrapolate,
            predict,
            remember,
            step_kernel,
            frozen_constants,
            compiled_stamp,
        ):
            dispatcher.recompile()
    _checked_cache = True
    return stale
