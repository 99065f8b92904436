"""What a compiled steady solution implies (numba): its contacts completed, its sums taken.

:func:`finish_contacts` completes the contacts the solver recorded into the buffer
``contacts_kernel`` returns for the solution (inactive contacts, gravity and inertia);
:func:`summarise` sums the mechanism powers and torques, the nuts' powers, the direct moment on
the screw and gravity's power on the spheres (:data:`SUMMARY_SIZE` entries) and lays out the
per-contact states (:data:`STATE_ROWS`), so that no numpy sums remain for the Python side. Used
by :mod:`ballscrew_twin.kernels.steady_solver` (whose dependency stamp covers this file).
"""

from __future__ import annotations

from numba import njit

from .contact_law import (
    contact_geometry,
    contact_law,
    law_constants,
)
from .contact_layout import (
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
    R_FORCE,
    R_MOMENT,
)
from .contacts import (
    scene_from_array,
)
from .steady_sphere import I_BALL_INERTIA, I_BALL_MASS, I_SCREW_SPEED, record_contact
from .vector3 import (
    _add,
    _cross,
    _dot,
    _helical,
    _scale,
    _sub,
)

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
#: ``models.steady_output.assemble`` divides them, so that no division remains in Python)
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
    ball_mass = scene[I_BALL_MASS]
    ball_inertia = scene[I_BALL_INERTIA]
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
            record_contact(out, i, j, fields, on_groove)
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
      ``models.steady_output.assemble`` and ``steady_problem.potential_energy_rate``), and
      the mechanisms' and nuts' powers and the drag over the screw speed [N m] (zero at
      standstill);
    - states (len(STATE_ROWS), 4 B): the per-contact states of ``ContactStates``, one row per
      field, contact 4 i + j, zero where inactive except the contact angle and the stiffness.
    """
    count = z.shape[0]
    summary[:] = 0.0
    ball_mass = scene[I_BALL_MASS]
    lead_rate = scene[3]
    z_t, z_b = scene[4], scene[5]  # screw axis (sin helix, 0, cos helix) in Frenet components
    pitch_radius = scene[2]
    screw_speed = scene[I_SCREW_SPEED]
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
