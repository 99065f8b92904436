"""Compiled contact laws: scalar loops over spheres and half grooves (numba).

This is the compiled twin of :func:`ballscrew_twin.models.contact_forces.evaluate_contacts`: same
inputs, same :class:`~ballscrew_twin.models.contact_forces.ContactEvaluation`, same laws and the
same order of floating-point operations wherever it matters, so the two agree to rounding
(test/kernels/test_contacts_kernel.py checks <= 1e-9 relative). The readable numpy reference stays
the definition of the model; read it and docs/model.md first. Equation numbers are the paper's
(Bertolino et al. 2021), deviations D1-D13 those of docs/model.md. Everything is SI: m, N, Pa, s,
rad, K.

Modules (each tested through this one):

- :mod:`~ballscrew_twin.kernels.scalar_laws`: one scalar ``@njit(inline="always")`` helper per
  law (Hertz, viscosity, film, Gupta factor, load share, Eyring friction, FR/FP, MER, MC, MP),
  each mirroring its numpy counterpart in :mod:`ballscrew_twin.physics`, and the copies of the
  physics modules' law constants;
- :mod:`~ballscrew_twin.kernels.contact_law`: one sphere - half groove contact
  (``law_constants``, ``contact_geometry``, ``contact_law`` = ``contact_kinetics`` of
  ``contact_statics``);
- :mod:`~ballscrew_twin.kernels.contact_layout`: the rows of the output buffer and of the
  dynamic model's statics; :mod:`~ballscrew_twin.kernels.vector3`: 3-tuple operations;
- here: :func:`contacts_kernel`, the ``@njit(cache=True)`` loop over B spheres x 4 half grooves.
  The scene enters as plain floats and one int (:func:`scene_arrays` flattens a
  ``ContactScene``). Laws are evaluated only for active contacts: an inactive contact has
  delta = 0, F_n = 0 and a zero contact area, so every force, moment and dissipation of the
  reference is exactly zero there, and the state arrays the reference masks with ``active`` are
  zero too; :func:`evaluate_contacts_compiled`, the drop-in replacement of
  ``evaluate_contacts``; and for the dynamic model, whose positions stay fixed over the
  evaluations of a time step, :func:`contacts_statics_kernel` (the velocity-independent part of
  every contact, ``contact_statics``, once per step) and :func:`contacts_kinetics_kernel` (the
  rest, ``contact_kinetics``, at each velocity), together ``contacts_kernel``'s dynamic path bit
  for bit.

The kernel returns two arrays: active (B, 4) and one stacked (N_ROWS, B, 4) buffer holding every
per-contact quantity (row ``CONTACT_FIELDS.index(name)``, constants ``F_APPROACH`` ... name the
rows), the groove forces and the balls' forces and moments; the wrapper hands out views of it.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

from ..params import ScrewGeometry
from ..physics.contact_types import ContactEvaluation, ContactScene
from ..physics.hertz import HertzContact
from .contact_law import (
    contact_geometry,
    contact_kinetics,
    contact_law,
    contact_statics,
    law_constants,
)
from .contact_layout import (
    F_ANGLE,
    F_APPROACH,
    F_AREA,
    F_DISS_CURVATURE,
    F_DISS_DAMPING,
    F_DISS_DRY,
    F_DISS_HYSTERESIS,
    F_DISS_LUBRICANT,
    F_DISS_ROLLING,
    F_DISS_SPIN,
    F_ENTRAINMENT,
    F_FILM,
    F_FRICTION_DRY,
    F_FRICTION_LUB,
    F_GROOVE_MZ,
    F_HERTZ_APPROACH,
    F_LOAD_SHARE,
    F_MAX_PRESSURE,
    F_MEAN_PRESSURE,
    F_MU_S,
    F_ROLL,
    F_SEMI_X,
    F_SEMI_Y,
    F_SHEAR_STRESS,
    F_SLIP,
    F_SPIN,
    F_STIFFNESS,
    F_TALLIAN,
    N_FIELDS,
    N_ROWS,
    R_FORCE,
    R_GROOVE_FORCE,
    R_MOMENT,
)
from .scalar_laws import VISCOSITY_LAWS
from .vector3 import _add, _cross, _dot, _helical, _scale, _sub

FloatArray = NDArray[np.float64]


# ----------------------------------------------------------------------------- the kernel
@njit(cache=True, error_model="numpy")
def contacts_kernel(
    ball_nb,
    kinematics,
    nut_offset,
    gravity_frenet,
    centre_velocity,
    nut_slide,
    approach_offset,
    dynamic,
    ball_radius,
    groove_radius,
    pitch_radius,
    lead_rate,
    sin_helix,
    cos_helix,
    cos2_helix,
    centre_offset,
    ogival_offset,
    inner_angle,
    outer_angle,
    temperature,
    screw_speed,
    e_star,
    e_reduced,
    viscosity_atm,
    ball_mass,
    ball_inertia,
    ball_share,
    surface_radius,
    law,
    eta0,
    t0,
    t1,
    eta1,
    rho0,
    alpha_rho,
    alpha_pv,
    beta,
    k_h,
    tau_e,
    tau_l,
    xi,
    h_r,
    mu_dry,
    v_r,
    roughness,
    damping,
):
    """Forces, moments, states and dissipation of B spheres x 4 half grooves.

    Arrays (C-contiguous float64): ball_nb (B, 2) [m], kinematics (B, 4) [rad/s], nut_offset
    (B,) [m], gravity_frenet (B, 3) [m/s^2], as ``evaluate_contacts``. Scalars: see
    :func:`scene_arrays` (SI units; ``law`` 0 Roelands, 1 exponential, 2 Walther).

    Returns:
        active (B, 4) bool, and out (N_ROWS, B, 4) float64: rows 0..N_FIELDS-1 the per-contact
        quantities named by CONTACT_FIELDS, rows R_GROOVE_FORCE + (0, 1, 2) the force of the ball
        on each half groove (t, n, b) [N], rows R_FORCE + k and R_MOMENT + k, column 0, the
        total force [N] and moment [N m] on each ball (one buffer: one allocation and one boxed
        array instead of four, which is most of the call overhead for small B).
    """
    count = ball_nb.shape[0]
    active_out = np.zeros((count, 4), dtype=np.bool_)
    out = np.zeros((N_ROWS, count, 4))
    constants = law_constants(
        ball_radius,
        groove_radius,
        pitch_radius,
        lead_rate,
        sin_helix,
        cos_helix,
        cos2_helix,
        centre_offset,
        ogival_offset,
        inner_angle,
        outer_angle,
        temperature,
        screw_speed,
        e_star,
        e_reduced,
        viscosity_atm,
        ball_mass,
        ball_inertia,
        ball_share,
        surface_radius,
        law,
        eta0,
        t0,
        t1,
        eta1,
        rho0,
        alpha_rho,
        alpha_pv,
        beta,
        k_h,
        tau_e,
        tau_l,
        xi,
        h_r,
        mu_dry,
        v_r,
        roughness,
        damping,
    )
    zhat = constants[4]
    with_offsets = approach_offset.shape[0] > 0  # defects (reference: approach_offset)

    for i in range(count):
        n_i = ball_nb[i, 0]
        b_i = ball_nb[i, 1]
        w_ball = kinematics[i, 0]
        omega = (kinematics[i, 1], kinematics[i, 2], kinematics[i, 3])
        r_ball = (0.0, n_i - pitch_radius, b_i)
        if dynamic:  # given centre velocity; contact points follow its t-progression
            v_centre = (centre_velocity[i, 0], centre_velocity[i, 1], centre_velocity[i, 2])
            w_ball = v_centre[0] / _helical(1.0, zhat, lead_rate, r_ball)[0]
        else:
            v_centre = _helical(w_ball, zhat, lead_rate, r_ball)
        f_sum = (0.0, 0.0, 0.0)
        m_sum = (0.0, 0.0, 0.0)
        for j in range(4):
            offset = approach_offset[i, j] if with_offsets else 0.0
            geometry = contact_geometry(j, constants, n_i, b_i, nut_offset[i], offset)
            on_ball, moment, on_groove, fields = contact_law(
                j, constants, geometry, n_i, b_i, w_ball, omega, r_ball, v_centre, nut_slide[i]
            )
            active = geometry[4]
            f_sum = _add(f_sum, on_ball)
            m_sum = _add(m_sum, moment)
            active_out[i, j] = active
            for k in range(3):
                out[R_GROOVE_FORCE + k, i, j] = on_groove[k]
            for k in range(N_FIELDS):
                out[k, i, j] = fields[k]

        # Steady use: gravity and the d'Alembert terms of the orbiting frame (section 7).
        # Dynamic use: the contact actions alone.
        if dynamic:
            for k in range(3):
                out[R_FORCE + k, i, 0] = f_sum[k]
                out[R_MOMENT + k, i, 0] = m_sum[k]
            continue
        orbit_rate = screw_speed + w_ball
        r_perp = _sub(r_ball, _scale(_dot(r_ball, zhat), zhat))
        inertial = _scale(ball_mass * orbit_rate * orbit_rate, r_perp)
        for k in range(3):
            out[R_FORCE + k, i, 0] = f_sum[k] + ball_mass * gravity_frenet[i, k] + inertial[k]
        omega_abs = _add(omega, _scale(screw_speed, zhat))
        gyro = _scale(orbit_rate, _cross(zhat, _scale(ball_inertia, omega_abs)))
        for k in range(3):
            out[R_MOMENT + k, i, 0] = m_sum[k] - gyro[k]
    return active_out, out


# ----------------------------------------------------------------------------- dynamic model
# contacts_statics_kernel writes one row of N_STATICS values per contact (contact_layout.py);
# contacts_kinetics_kernel finishes the evaluation from it.


@njit(inline="always")
def _law_constants_from_array(p, screw_speed):
    """law_constants of the scene's parameter array ``p`` (``scene_arrays`` order) at the screw
    speed ``screw_speed`` [rad/s] (in place of p[12])."""
    return law_constants(
        p[0], p[1], p[2], p[3], p[4], p[5], p[6], p[7], p[8], p[9], p[10], p[11],
        screw_speed, p[13], p[14], p[15], p[16], p[17], p[18], p[19],
        int(p[20]), p[21], p[22], p[23], p[24], p[25], p[26], p[27], p[28], p[29], p[30],
        p[31], p[32], p[33], p[34], p[35], p[36], p[37],
    )  # fmt: skip


@njit(cache=True)
def contacts_statics_kernel(ball_nb, nut_offset, approach_offset, p, statics):
    """The velocity-independent part of every contact, written to ``statics`` (B, 4, N_STATICS;
    the row's layout in ``contact_layout.py``).

    Args:
        ball_nb: (B, 2) ball-centre offsets (n, b) from the ideal helix [m]; nut_offset: (B,)
            b-offset of each ball's nut groove [m]; approach_offset: (B, 4) defect offsets of
            the approach [m], or (0, 4) for none; p: the scalar parameters of contacts_kernel
            (``scene_arrays``) as float64 (the screw speed p[12] is not used).
    """
    constants = _law_constants_from_array(p, p[12])
    pitch_radius = p[2]
    with_offsets = approach_offset.shape[0] > 0
    for i in range(ball_nb.shape[0]):
        n_i = ball_nb[i, 0]
        b_i = ball_nb[i, 1]
        r_ball = (0.0, n_i - pitch_radius, b_i)
        for j in range(4):
            offset = approach_offset[i, j] if with_offsets else 0.0
            geometry = contact_geometry(j, constants, n_i, b_i, nut_offset[i], offset)
            (
                delta, r_x, r_y, stiffness, root_stiffness, semi_x, semi_y, h_approach, p_max,
                p_mean, area, f_elastic, d, arm, r_point, eta, limit, semi_major, spin_factor,
            ) = contact_statics(j, constants, geometry, r_ball)  # fmt: skip
            row = statics[i, j]
            row[0] = geometry[0]
            row[1] = geometry[1]
            row[2] = geometry[2]
            row[3] = geometry[3]
            row[4] = 1.0 if geometry[4] else 0.0
            scalars = (delta, r_x, r_y, stiffness, root_stiffness, semi_x, semi_y, h_approach,
                       p_max, p_mean, area, f_elastic)  # fmt: skip
            for k in range(12):
                row[5 + k] = scalars[k]
            for k in range(3):
                row[17 + k] = d[k]
                row[20 + k] = arm[k]
                row[23 + k] = r_point[k]
            row[26] = eta
            row[27] = limit
            row[28] = semi_major
            row[29] = spin_factor


@njit(cache=True, error_model="numpy")
def contacts_kinetics_kernel(statics, ball_nb, omega, centre_velocity, nut_slide, p, screw_speed):
    """contacts_kernel's dynamic path from the contacts' ``statics`` (contacts_statics_kernel at
    the same positions): the same active (B, 4) and out (N_ROWS, B, 4), bit for bit.

    Args:
        statics: (B, 4, N_STATICS); ball_nb: (B, 2) [m]; omega: (B, 3) sphere angular velocity
            relative to the screw (t, n, b) [rad/s]; centre_velocity: (B, 3) [m/s]; nut_slide:
            (B,) [m/s]; p: as contacts_statics_kernel; screw_speed: [rad/s].
    """
    count = ball_nb.shape[0]
    active_out = np.zeros((count, 4), dtype=np.bool_)
    out = np.zeros((N_ROWS, count, 4))
    constants = _law_constants_from_array(p, screw_speed)
    zhat = constants[4]
    pitch_radius = p[2]
    lead_rate = p[3]
    for i in range(count):
        r_ball = (0.0, ball_nb[i, 0] - pitch_radius, ball_nb[i, 1])
        w = (omega[i, 0], omega[i, 1], omega[i, 2])
        v_centre = (centre_velocity[i, 0], centre_velocity[i, 1], centre_velocity[i, 2])
        w_ball = v_centre[0] / _helical(1.0, zhat, lead_rate, r_ball)[0]
        f_sum = (0.0, 0.0, 0.0)
        m_sum = (0.0, 0.0, 0.0)
        for j in range(4):
            row = statics[i, j]
            active = row[4] > 0.0
            geometry = (row[0], row[1], row[2], row[3], active)
            kept = (
                row[5], row[6], row[7], row[8], row[9], row[10], row[11], row[12], row[13],
                row[14], row[15], row[16], (row[17], row[18], row[19]),
                (row[20], row[21], row[22]), (row[23], row[24], row[25]), row[26], row[27],
                row[28], row[29],
            )  # fmt: skip
            on_ball, moment, on_groove, fields = contact_kinetics(
                j, constants, geometry, kept, w_ball, w, v_centre, nut_slide[i]
            )
            f_sum = _add(f_sum, on_ball)
            m_sum = _add(m_sum, moment)
            active_out[i, j] = active
            for k in range(3):
                out[R_GROOVE_FORCE + k, i, j] = on_groove[k]
            for k in range(N_FIELDS):
                out[k, i, j] = fields[k]
        for k in range(3):
            out[R_FORCE + k, i, 0] = f_sum[k]
            out[R_MOMENT + k, i, 0] = m_sum[k]
    return active_out, out


@njit(inline="always")
def scene_from_array(p):
    """The scalar parameters of :func:`contacts_kernel` (``scene_arrays`` order) from their
    float64 array form ``p`` (38,): an array crosses into compiled code faster than a tuple."""
    return (
        p[0], p[1], p[2], p[3], p[4], p[5], p[6], p[7], p[8], p[9], p[10], p[11], p[12], p[13],
        p[14], p[15], p[16], p[17], p[18], p[19], int(p[20]), p[21], p[22], p[23], p[24], p[25],
        p[26], p[27], p[28], p[29], p[30], p[31], p[32], p[33], p[34], p[35], p[36], p[37],
    )  # fmt: skip


# ----------------------------------------------------------------------------- Python side
def scene_arrays(scene: ContactScene) -> tuple[float | int, ...]:
    """Flatten ``scene`` into the scalar parameters of :func:`contacts_kernel`, in its order.

    Geometry at the scene's temperature: r_b, r_s, r_m [m], p/(2 pi) [m], sin l, cos l, cos^2 l,
    H, L [m], DCA_i, DCA_o [rad]; scene: T [K], screw speed [rad/s], E*, E' [Pa], eta_0T [Pa s],
    ball mass [kg], inertia [kg m^2], delta_ball/delta [-], R_c [m]; lubricant: law code (int),
    eta0 [Pa s], T0, T1 [K], eta1 [Pa s], rho0 [kg/m^3], alpha_rho [kg m^-3 K^-1], alpha_pv
    [1/Pa], beta [1/K], k_h [W/(m K)], tau_e, tau_L [Pa], xi [-], h_R [m]; contact: mu_dry [-],
    v_r [m/s]; composite roughness [m].
    """
    geom = scene.geometry
    if not isinstance(geom, ScrewGeometry):
        raise TypeError(f"scene.geometry must be a ScrewGeometry, got {type(geom).__name__}")
    cfg = scene.config
    lub = cfg.lubricant
    helix = geom.helix_angle
    return (
        float(geom.ball_radius),
        float(geom.groove_radius),
        float(geom.pitch_radius),
        float(geom.lead / (2.0 * math.pi)),
        math.sin(helix),
        math.cos(helix),
        math.cos(helix) ** 2,
        float(geom.centre_offset),
        float(geom.ogival_offset),
        float(geom.inner_containment_angle),
        float(geom.outer_containment_angle),
        float(scene.temperature),
        float(scene.screw_speed),
        float(scene.e_star),
        float(scene.e_reduced),
        float(scene.viscosity_atm),
        float(scene.ball_mass),
        float(scene.ball_inertia),
        float(scene.deformation_ball_share),
        float(scene.surface_radius),
        VISCOSITY_LAWS.index(lub.viscosity_law),
        float(lub.viscosity_reference),
        float(lub.reference_temperature),
        float(lub.second_temperature),
        float(lub.viscosity_second),
        float(lub.density_reference),
        float(lub.density_temperature_coefficient),
        float(lub.pressure_viscosity_coefficient),
        float(lub.viscosity_temperature_coefficient),
        float(lub.thermal_conductivity),
        float(lub.eyring_stress),
        float(lub.limiting_shear_stress),
        float(lub.limiting_shear_pressure_coefficient),
        float(lub.residual_layer),
        float(cfg.contact.dry_friction_coefficient),
        float(cfg.contact.dry_friction_regularisation_speed),
        float(cfg.composite_roughness),
        float(cfg.contact.damping_coefficient),
    )


# One-entry cache: the solver evaluates one scene many times in a row. The scene is frozen, so
# identity is enough; keeping a reference to it keeps its id from being reused.
_last_scene: tuple[ContactScene, tuple[float | int, ...]] | None = None


def scene_parameters(scene: ContactScene) -> tuple[float | int, ...]:
    """``scene_arrays(scene)``, computed once for consecutive calls with the same scene."""
    global _last_scene
    cached = _last_scene
    if cached is not None and cached[0] is scene:
        return cached[1]
    params = scene_arrays(scene)
    _last_scene = (scene, params)
    return params


_NO_VELOCITY = np.zeros((0, 3))
_NO_OFFSET = np.zeros((0, 4))


def _as_input(array: FloatArray) -> FloatArray:
    return np.ascontiguousarray(array, dtype=np.float64)


def evaluate_contacts_compiled(
    scene: ContactScene,
    ball_nb: FloatArray,
    kinematics: FloatArray,
    nut_offset: FloatArray,
    gravity_frenet: FloatArray,
    centre_velocity: FloatArray | None = None,
    nut_slide: FloatArray | None = None,
    approach_offset: FloatArray | None = None,
) -> ContactEvaluation:
    """Drop-in, compiled replacement of ``evaluate_contacts`` (same arguments and result).

    Args:
        scene: constants of the operating point.
        ball_nb: (B, 2) ball-centre offsets (n, b) from the ideal helix point [m].
        kinematics: (B, 4) orbital rate w_B and ball angular velocity (t, n, b) relative to the
            screw [rad/s].
        nut_offset: (B,) b-offset e of each ball's nut groove [m].
        gravity_frenet: (B, 3) gravitational acceleration in Frenet components [m/s^2].
    """
    count = len(ball_nb)
    dynamic = centre_velocity is not None
    velocity = _NO_VELOCITY if centre_velocity is None else _as_input(centre_velocity)
    active, c = contacts_kernel(
        _as_input(ball_nb),
        _as_input(kinematics),
        _as_input(nut_offset),
        _as_input(gravity_frenet),
        velocity,
        _as_input(nut_slide) if nut_slide is not None else np.zeros(count),
        _NO_OFFSET if approach_offset is None else _as_input(approach_offset),
        dynamic,
        *scene_parameters(scene),
    )
    return evaluation_from_buffer(active, c)


def evaluation_from_buffer(active: NDArray[np.bool_], c: FloatArray) -> ContactEvaluation:
    """The :class:`ContactEvaluation` view of the kernel's outputs ``active`` (B, 4) and ``c``
    (N_ROWS, B, 4) (no copies; layout in :func:`contacts_kernel`)."""
    return ContactEvaluation(
        force=c[R_FORCE:R_MOMENT, :, 0].T,
        moment=c[R_MOMENT:N_ROWS, :, 0].T,
        groove_force=c[R_GROOVE_FORCE:R_FORCE].transpose(1, 2, 0),
        groove_moment_z=c[F_GROOVE_MZ],
        active=active,
        approach=c[F_APPROACH],
        contact_angle=c[F_ANGLE],
        hertz=HertzContact(
            semi_axis_x=c[F_SEMI_X],
            semi_axis_y=c[F_SEMI_Y],
            approach=c[F_HERTZ_APPROACH],
            max_pressure=c[F_MAX_PRESSURE],
            mean_pressure=c[F_MEAN_PRESSURE],
            area=c[F_AREA],
            stiffness=c[F_STIFFNESS],
        ),
        film_total=c[F_FILM],
        tallian=c[F_TALLIAN],
        load_share=c[F_LOAD_SHARE],
        slip=c[F_SLIP],
        spin=c[F_SPIN],
        roll=c[F_ROLL],
        entrainment=c[F_ENTRAINMENT],
        friction_lubricant=c[F_FRICTION_LUB],
        friction_dry=c[F_FRICTION_DRY],
        shear_stress=c[F_SHEAR_STRESS],
        sliding_coefficient=c[F_MU_S],
        dissipation={
            "lubricant_shear": c[F_DISS_LUBRICANT],
            "dry_contact": c[F_DISS_DRY],
            "rolling_resistance": c[F_DISS_ROLLING],
            "hysteresis": c[F_DISS_HYSTERESIS],
            "curvature": c[F_DISS_CURVATURE],
            "spin": c[F_DISS_SPIN],
            "normal_damping": c[F_DISS_DAMPING],
        },
    )
