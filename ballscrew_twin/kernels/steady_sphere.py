"""One sphere of the compiled steady solver (numba): its balance, residuals and Jacobian block.

:func:`sphere_balance` is the force and moment balance of one sphere and its axial push on its
nut, through the contact law of the contact kernel
(:func:`ballscrew_twin.kernels.contacts.contact_law`, the same code); :func:`linearise` evaluates
it for every sphere with its seven unknowns (z_i, e_k) seeded as dual numbers
(:mod:`ballscrew_twin.kernels.dual`): one pass gives the residuals and the exact 7 x 7 Jacobian
blocks; :func:`residuals` evaluates it with plain floats and records the contacts in the layout
of ``contacts_kernel``. Used by :mod:`ballscrew_twin.kernels.steady_solver` (whose dependency
stamp covers this file). Units: SI throughout (m, rad/s, N, N m).
"""

from __future__ import annotations

import numpy as np
from numba import njit, types
from numba.extending import overload

from .contact_law import (
    contact_geometry,
    contact_law,
    law_constants,
)
from .contact_layout import (
    IS_NUT,
    N_FIELDS,
    R_FORCE,
    R_GROOVE_FORCE,
    R_MOMENT,
)
from .contacts import (
    scene_from_array,
)
from .dual import make_dual
from .vector3 import (
    _add,
    _cross,
    _dot,
    _helical,
    _scale,
    _sub,
)

# Positions in the tuple of scene_arrays(scene) (the scalar parameters of contacts_kernel).
I_SCREW_SPEED = 12
I_BALL_MASS = 16
I_BALL_INERTIA = 17

_UNIT = (
    (1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0),
    (0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0),
    (0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0),
    (0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0),
    (0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0),
    (0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0),
    (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0),
)


def record_contact(out, i, j, fields, on_groove):
    """Store one contact's CONTACT_FIELDS and groove force into ``out[:, i, j]`` (compiled
    only, see its overload: a no-op for dual numbers, whose value parts are not recorded)."""


def _record_sums(out, i, force, moment):
    """Store a sphere's summed contact force and moment into column 0 of the R_FORCE and
    R_MOMENT rows of ``out`` (compiled only; a no-op for dual numbers)."""


def _all_float(values):
    return all(isinstance(t, types.Float) for t in values.types)


@overload(record_contact)
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
            record_contact(out, i, j, fields, on_groove)
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
    masses = (scene[I_BALL_MASS], scene[I_BALL_INERTIA])
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
            (scene[I_BALL_MASS], scene[I_BALL_INERTIA]),
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
