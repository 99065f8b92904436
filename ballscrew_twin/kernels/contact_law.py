"""Compiled law of one sphere - half groove contact (numba), built from the scalar laws.

:func:`law_constants` gathers a scene's constants; :func:`contact_geometry` finds where a sphere
and a half groove meet; :func:`contact_law` evaluates every law of the reference
(:func:`ballscrew_twin.models.contact_forces.evaluate_contacts`) for that contact, as
:func:`contact_kinetics` of :func:`contact_statics` (the velocity-independent part, which the
dynamic model keeps over a time step). Equation numbers are the paper's (Bertolino et al. 2021),
deviations D1-D16 those of docs/model.md. Everything is SI: m, N, Pa, s, rad, K.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .contact_layout import IS_NUT, SIDE_B, SIDE_N
from .scalar_laws import (
    FILM_MIN_LOAD,
    ROELANDS_LN_ETA_INF,
    ROELANDS_PRESSURE_SCALE,
    curvature_moment,
    ellipse_shape,
    film_central_isothermal,
    hertz_from_approach,
    hertz_stiffness,
    hysteresis_moment,
    load_share_asperities,
    rolling_resistance_force,
    sliding_friction,
    smoothed_speed,
    spin_moment_factor,
    thermal_reduction_factor,
    viscosity_atmospheric,
    viscosity_pressure,
)
from .vector3 import _add, _cross, _dot, _helical, _scale, _sub, _unit

# models/contact_forces.py (D11)
SPIN_SLIDING_FACTOR = 4.0 / (3.0 * math.pi)


# ----------------------------------------------------------------------------- one contact
@njit(cache=True)
def law_constants(
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
    """The constants :func:`contact_law` reads, from the scene's scalars (``scene_arrays``
    order): the screw axis zhat in Frenet components, eta_T(T) [Pa s] for the Eyring law, the
    Roelands index Z [-] (lubricant.py) and the others as they are."""
    zhat = (sin_helix, 0.0, cos_helix)
    eta_t = viscosity_atmospheric(law, temperature, eta0, t0, t1, eta1, rho0, alpha_rho, beta)
    z_index = alpha_pv / (ROELANDS_PRESSURE_SCALE * (math.log(eta0) + ROELANDS_LN_ETA_INF))
    return (
        ball_radius,
        groove_radius,
        pitch_radius,
        lead_rate,
        zhat,
        cos2_helix,
        centre_offset,
        ogival_offset,
        inner_angle,
        outer_angle,
        screw_speed,
        e_star,
        e_reduced,
        viscosity_atm,
        ball_share,
        surface_radius,
        eta_t,
        z_index,
        alpha_pv,
        beta,
        k_h,
        tau_e,
        tau_l,
        xi,
        h_r,
        mu_dry,
        max(mu_dry, 1e-6),
        v_r,
        roughness,
        damping,
    )


@njit(inline="always")
def contact_geometry(j, constants, n_i, b_i, e, offset):
    """Where sphere and half groove ``j`` meet (Eqs. 5-8, 17, 22).

    Args:
        j: half groove (0 S1, 1 S2, 2 N1, 3 N2); constants: :func:`law_constants`.
        n_i, b_i: ball-centre offset (n, b) from the ideal helix [m].
        e: b-offset of the nut's groove [m].
        offset: added to the approach [m] (defects; 0 without).

    Returns:
        (d_n, d_b) unit normal in the normal plane, approach [m] (negative when apart),
        contact angle [rad], and whether the contact exists.
    """
    ball_radius, groove_radius = constants[0], constants[1]
    centre_offset, ogival_offset = constants[6], constants[7]
    inner_angle, outer_angle = constants[8], constants[9]
    # Curvature centre of the half groove: (-s_n H, -s_b L (+ e on the nut)).
    rel_n = n_i - -SIDE_N[j] * centre_offset
    if IS_NUT[j]:
        rel_b = b_i - (-SIDE_B[j] * ogival_offset + e)
    else:
        rel_b = b_i - -SIDE_B[j] * ogival_offset
    dist = math.hypot(rel_n, rel_b)
    safe_dist = max(dist, 1e-30)
    d_n = rel_n / safe_dist
    d_b = rel_b / safe_dist
    approach = dist + ball_radius - groove_radius
    approach += offset
    angle = math.atan2(SIDE_B[j] * d_b, SIDE_N[j] * d_n)
    active = approach > 0.0 and angle >= inner_angle and angle <= outer_angle
    return d_n, d_b, approach, angle, active


@njit(inline="always")
def contact_law(j, constants, geometry, n_i, b_i, w_ball, omega, r_ball, v_centre, slide):
    """Sphere - half groove ``j`` contact: every law of the reference for one contact.

    Args:
        j: half groove (0 S1, 1 S2, 2 N1, 3 N2).
        constants: :func:`law_constants`; geometry: :func:`contact_geometry` of the contact.
        n_i, b_i: ball-centre offset (n, b) from the ideal helix [m].
        w_ball: orbital rate of the contact points along the thread [rad/s].
        omega: sphere angular velocity (t, n, b) relative to the screw [rad/s].
        r_ball: centre from the axis (t, n, b) [m]; v_centre: its velocity [m/s].
        slide: axial velocity of the nut beyond its helical motion [m/s].

    The state arguments may be floats or dual numbers (:mod:`ballscrew_twin.kernels.dual`): the
    same code then also carries their partial derivatives. An inactive contact exerts nothing
    (zero force, moment and groove force), whatever its other fields.

    It is :func:`contact_kinetics` of :func:`contact_statics` (the dynamic model keeps the
    latter over a time step, in which the positions do not move).

    Returns:
        (force on the ball (t, n, b) [N], moment on the ball about its centre [N m], force of
        the ball on the groove [N], the CONTACT_FIELDS values in their order).
    """
    statics = contact_statics(j, constants, geometry, r_ball)
    return contact_kinetics(j, constants, geometry, statics, w_ball, omega, v_centre, slide)


@njit(inline="always")
def contact_statics(j, constants, geometry, r_ball):
    """The velocity-independent part of :func:`contact_law` for one contact: curvatures,
    Hertz ellipse and stiffness, elastic normal force, contact normal and point, and the
    pressure-dependent lubricant properties.

    Args:
        j: half groove (0 S1, 1 S2, 2 N1, 3 N2); constants: :func:`law_constants`;
        geometry: :func:`contact_geometry`; r_ball: centre from the axis (t, n, b) [m].

    Returns:
        (delta [m], R_x [m], R_y [m], K_H [N m^-1.5], sqrt(K_H) [N^0.5 m^-0.75], semi-axes
        x, y [m], Hertz approach [m], p0 [Pa], mean pressure [Pa], area [m^2], elastic normal
        force K_H delta^1.5 [N], unit normal d (t, n, b), arm (a d) [m], contact point from the
        axis [m], eta(p_mean, T) [Pa s], tau_lim [Pa], semi-major axis [m], spin-moment factor
        [-]); the last four are 0 for an inactive contact.
    """
    ball_radius, groove_radius, pitch_radius, lead_rate, zhat, cos2_helix = constants[:6]
    e_star, ball_share = constants[11], constants[14]
    eta_t, z_index, tau_l, xi = constants[16], constants[17], constants[22], constants[23]
    d_n, d_b, approach, angle, active = geometry
    delta = approach if active else 0.0
    # Curvatures (Meusnier) and reduced radii.
    cos_a = math.cos(angle)
    if IS_NUT[j]:
        k_roll = -1.0 * cos_a * cos2_helix / (pitch_radius + ball_radius * cos_a)
    else:
        k_roll = 1.0 * cos_a * cos2_helix / (pitch_radius + -ball_radius * cos_a)
    r_x = 1.0 / (1.0 / ball_radius + k_roll)
    r_y = 1.0 / (1.0 / ball_radius + -1.0 / groove_radius)
    ratio, ell_k, ell_e, curv_sum = ellipse_shape(r_x, r_y)
    stiffness = hertz_stiffness(ratio, ell_k, ell_e, curv_sum, e_star)
    minor, major, h_approach, p_max, p_mean, area = hertz_from_approach(
        delta, ratio, ell_k, ell_e, curv_sum, e_star
    )
    if r_x > r_y:
        semi_x, semi_y = major, minor
    else:
        semi_x, semi_y = minor, major
    f_elastic = stiffness * (delta * math.sqrt(delta))  # Eq. 18, static part

    # Helicoid normal (D12) and contact point.
    d_plane = (0.0, d_n, d_b)
    arm_length = ball_radius - ball_share * delta
    field = _helical(1.0, zhat, lead_rate, r_ball)  # d . V(F + a d) = d . V(F)
    d, _ = _unit(_sub(d_plane, _scale(_dot(d_plane, field) / _dot(field, field), field)))
    arm = _scale(arm_length, d)
    r_point = _add(r_ball, arm)

    eta = 0.0
    limit = 0.0
    semi_major = 0.0
    spin_factor = 0.0
    if active:
        eta = viscosity_pressure(eta_t, p_mean, z_index)
        limit = tau_l + xi * max(p_mean, 0.0)
        semi_major = max(semi_x, semi_y)
        semi_minor = min(semi_x, semi_y)
        ellipticity = semi_major / max(semi_minor, 1e-300)
        spin_factor = spin_moment_factor(ellipticity)
    return (
        delta,
        r_x,
        r_y,
        stiffness,
        math.sqrt(stiffness),
        semi_x,
        semi_y,
        h_approach,
        p_max,
        p_mean,
        area,
        f_elastic,
        d,
        arm,
        r_point,
        eta,
        limit,
        semi_major,
        spin_factor,
    )


@njit(inline="always")
def contact_kinetics(j, constants, geometry, statics, w_ball, omega, v_centre, slide):
    """The velocity-dependent part of :func:`contact_law` for one contact, given its
    :func:`contact_statics` ``statics`` (arguments and result as :func:`contact_law`)."""
    (
        ball_radius,
        _,
        _,
        lead_rate,
        zhat,
        _,
        _,
        _,
        _,
        _,
        screw_speed,
        _,
        e_reduced,
        viscosity_atm,
        _,
        surface_radius,
        _,
        _,
        alpha_pv,
        beta,
        k_h,
        tau_e,
        _,
        _,
        h_r,
        mu_dry,
        mu_dry_mer,
        v_r,
        roughness,
        damping,
    ) = constants
    _, _, approach, angle, active = geometry
    (
        _,
        r_x,
        r_y,
        stiffness,
        root_stiffness,
        semi_x,
        semi_y,
        h_approach,
        p_max,
        p_mean,
        area,
        f_n,
        d,
        arm,
        r_point,
        eta,
        limit,
        semi_major,
        spin_factor,
    ) = statics
    w_nut = -screw_speed
    # Velocities at the contact point.
    v_ball_point = _add(v_centre, _cross(omega, arm))
    if IS_NUT[j]:
        v_groove = _add(_helical(w_nut, zhat, lead_rate, r_point), _scale(slide, zhat))
        omega_groove = _scale(w_nut, zhat)
    else:
        v_groove = (0.0, 0.0, 0.0)
        omega_groove = (0.0, 0.0, 0.0)
    v_contact = _helical(w_ball, zhat, lead_rate, r_point)
    # Eqs. 18-19: saturated damping on the approach rate (zero in a steady state).
    rate = _dot(_sub(v_centre, v_groove), d)
    # Smooth saturation of the damping at the elastic force (reference: hertz, D14).
    damp_force = f_n * math.tanh(damping * root_stiffness * rate / f_n) if f_n > 0.0 else 0.0
    f_n = f_n + damp_force
    rel = _sub(v_ball_point, v_groove)
    slip_vec = _sub(rel, _scale(_dot(rel, d), d))
    slip_dir, slip = _unit(slip_vec)
    u1 = v_ball_point[0] - v_contact[0]
    u2 = v_groove[0] - v_contact[0]
    entrain = 0.5 * (u1 + u2)
    e_share = entrain / smoothed_speed(entrain)  # FR's share along t (rolling.py, D16)
    omega_rel = _sub(omega, omega_groove)
    spin = _dot(omega_rel, d)
    roll_dir, roll = _unit(_sub(omega_rel, _scale(spin, d)))
    roll_share = ball_radius * roll / smoothed_speed(ball_radius * roll)  # MER, MC (D16)

    lub_c = 0.0
    dry_c = 0.0
    tau = 0.0
    mu_s = 0.0
    h_tot = 0.0
    tallian = 0.0
    share = 0.0
    mer = 0.0
    mc = 0.0
    mp = 0.0
    fr = 0.0
    fp = 0.0
    if active:
        # Lubrication (Eqs. 26-33, 37-38).
        srr = abs(u1 - u2) / smoothed_speed(entrain)
        h_iso = film_central_isothermal(f_n, entrain, viscosity_atm, r_x, r_y, e_reduced, alpha_pv)
        c_th = thermal_reduction_factor(p_max, e_reduced, viscosity_atm, beta, entrain, k_h, srr)
        h_tot = c_th * h_iso + h_r
        tallian = h_tot / roughness if roughness > 0.0 else np.inf
        share = load_share_asperities(tallian)
        # Sliding friction at the centre slip and the spin sliding (Eqs. 34-36, 45).
        film_safe = max(h_tot, 1e-12)
        lub_c, dry_c, _ = sliding_friction(
            slip, eta, limit, film_safe, area, share, f_n, tau_e, mu_dry, v_r
        )
        v_spin = SPIN_SLIDING_FACTOR * semi_major * abs(spin)
        lub_s, dry_s, _ = sliding_friction(
            v_spin, eta, limit, film_safe, area, share, f_n, tau_e, mu_dry, v_r
        )
        mp = spin_factor * semi_major * (lub_s + dry_s)
        lub_m, dry_m, tau = sliding_friction(
            slip + v_spin, eta, limit, film_safe, area, share, f_n, tau_e, mu_dry, v_r
        )
        if f_n > FILM_MIN_LOAD:  # unloaded: mu_s = 0 (reference, D15)
            mu_s = (lub_m + dry_m) / f_n
        mer = hysteresis_moment(f_n, ball_radius, r_y / r_x, mu_s, mu_dry_mer)
        mc = curvature_moment(f_n, semi_y, surface_radius, mu_s)
        fr = rolling_resistance_force(f_n, entrain, viscosity_atm, r_x, r_y, e_reduced)
        fp = 2.0 * fr * r_x / (r_x + ball_radius)  # Eq. 42
    f_centre = lub_c + dry_c

    # Forces and moments on the ball (Eqs. 46-47) and on the groove (48-49, D13).
    e_dir = (e_share, 0.0, 0.0)
    contact_on_ball = _sub(_sub(_scale(-f_n, d), _scale(f_centre, slip_dir)), _scale(fr, e_dir))
    # FP opposes the centre's translation relative to the groove, taken in the inertial frame
    # (reference: rel_centre, D13).
    rel_centre = _add(
        _sub(v_centre, v_groove), _scale(screw_speed, _cross(zhat, _scale(-1.0, arm)))
    )
    fp_sign = -rel_centre[0] / smoothed_speed(rel_centre[0])  # its share along t (D16)
    pressure_on_ball = (fp * fp_sign, 0.0, 0.0)
    spin_sign = 1.0 if spin > 0.0 else (-1.0 if spin < 0.0 else 0.0)
    free_moment = _sub(_scale(-(mer + mc) * roll_share, roll_dir), _scale(mp * spin_sign, d))
    on_ball = _add(contact_on_ball, pressure_on_ball)
    moment = _add(_cross(arm, contact_on_ball), free_moment)
    on_groove = _scale(-1.0, on_ball)
    groove_moment = _sub(_cross(r_point, on_groove), free_moment)
    fields = (
        approach,
        angle,
        f_n,
        semi_x,
        semi_y,
        h_approach,
        p_max,
        p_mean,
        area,
        stiffness,
        h_tot,
        tallian,
        share,
        slip if active else 0.0,
        spin,
        roll,
        entrain,
        lub_c,
        dry_c,
        tau,
        mu_s,
        _dot(groove_moment, zhat),
        lub_c * slip,
        dry_c * slip,
        -fp * (fp_sign * rel_centre[0]) + fr * (e_share * slip_vec[0]),
        mer * roll_share * roll,
        mc * roll_share * roll,
        mp * abs(spin),
        damp_force * rate if active else 0.0,
    )
    return on_ball, moment, on_groove, fields
