"""Forces and moments of every ball-groove contact for given ball states (reference, numpy).

One call evaluates all balls and all four half grooves at once: no Python loop over spheres.
The steady-state model drives it with a Newton solver; the dynamic model will call the same
laws. Frames and numbering: :mod:`ballscrew_twin.physics.geometry`.

Kinematics are written in the frame of the screw. Everything that moves along the thread does
so by a helical motion about z with the screw's lead: the ball centre (rate w_B), the contact
points (w_B), the nut (w_N = -screw speed). A helical motion with rate w moves a point r (from
the axis) with velocity w (z x r + p/(2 pi) z).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from ..params import TwinConfig
from ..physics import film, geometry, hertz, lubricant, rolling, traction
from ..physics.contact_types import ContactEvaluation, ContactScene

FloatArray = NDArray[np.float64]

SPIN_SLIDING_FACTOR = 4.0 / (3.0 * math.pi)  # mean |y| / a_y under a Hertz pressure, thin ellipse


def make_scene(config: TwinConfig, temperature: float, screw_speed: float) -> ContactScene:
    """Thermally expanded geometry and lubricant state at ``temperature`` [K]."""
    geom = geometry.thermally_expanded(config.screw, config.materials, temperature)
    mats = config.materials
    e_star = float(
        hertz.effective_modulus(
            mats.ball.young_modulus,
            mats.ball.poisson_ratio,
            mats.screw.young_modulus,
            mats.screw.poisson_ratio,
        )
    )
    d_ball, _ = hertz.deformation_split(
        1.0,
        mats.ball.young_modulus,
        mats.ball.poisson_ratio,
        mats.screw.young_modulus,
        mats.screw.poisson_ratio,
    )
    mass = mats.ball.density * 4.0 / 3.0 * math.pi * geom.ball_radius**3
    return ContactScene(
        config=config,
        geometry=geom,
        temperature=temperature,
        screw_speed=screw_speed,
        e_star=e_star,
        e_reduced=2.0 * e_star,
        viscosity_atm=float(lubricant.viscosity_atmospheric(config.lubricant, temperature)),
        ball_mass=mass,
        ball_inertia=0.4 * mass * geom.ball_radius**2,
        deformation_ball_share=float(d_ball),
        surface_radius=rolling.deformed_surface_radius(geom.ball_radius, geom.groove_radius),
    )


def cross(a: FloatArray, b: FloatArray) -> FloatArray:
    return np.asarray(np.cross(a, b))


def dot(a: FloatArray, b: FloatArray) -> FloatArray:
    return np.asarray(np.einsum("...i,...i->...", a, b))


def unit(v: FloatArray) -> tuple[FloatArray, FloatArray]:
    norm = np.sqrt(dot(v, v))
    return v / np.maximum(norm, 1e-300)[..., None], norm


def sliding_friction(
    scene: ContactScene,
    speed: FloatArray,
    normal_force: FloatArray,
    area: FloatArray,
    mean_pressure: FloatArray,
    film_total: FloatArray,
    load_share: FloatArray,
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Friction magnitude at sliding speed ``speed`` [m/s], Eqs. 34-36 regularised (D6).

    F(v) = [ (1 - f) A tau(sqrt(v^2 + v_r^2)) + f mu_dry F_n ] tanh(v / v_r): the paper's law
    above the threshold speed v_r, linear in v below it (section 3 of the paper), smooth.

    Returns:
        (lubricant part [N], dry part [N], lubricant shear stress tau [Pa]).
    """
    lub = scene.config.lubricant
    law = scene.config.contact
    v_r = law.dry_friction_regularisation_speed
    eta = lubricant.viscosity(lub, mean_pressure, scene.temperature)
    rate = traction.shear_rate(np.hypot(speed, v_r), np.maximum(film_total, 1e-12))
    limit = traction.limiting_shear_stress(
        lub.limiting_shear_stress, lub.limiting_shear_pressure_coefficient, mean_pressure
    )
    tau = traction.eyring_shear_stress(eta, rate, lub.eyring_stress, limit)
    ramp = traction.dry_friction_factor(speed, v_r)
    lub_part, dry_part = traction.friction_force(
        tau, area, load_share, law.dry_friction_coefficient, 1.0, normal_force
    )
    return np.asarray(lub_part * ramp), np.asarray(dry_part * ramp), np.asarray(tau * ramp)


def evaluate_contacts(
    scene: ContactScene,
    ball_nb: FloatArray,
    kinematics: FloatArray,
    nut_offset: FloatArray,
    gravity_frenet: FloatArray,
    centre_velocity: FloatArray | None = None,
    nut_slide: FloatArray | None = None,
    approach_offset: FloatArray | None = None,
) -> ContactEvaluation:
    """Contact forces, moments, states and dissipation of B balls.

    Steady use (default): each ball centre moves along the thread by the helical motion of rate
    w_B, and ``force``/``moment`` include gravity and the d'Alembert terms of the orbiting frame
    (centrifugal force, gyroscopic moment), so that they vanish in equilibrium. Dynamic use
    (``centre_velocity`` given): the centre moves with that velocity, and ``force``/``moment``
    are the contact actions alone (the caller integrates in the inertial frame).

    Args:
        scene: constants of the operating point.
        ball_nb: (B, 2) ball-centre offsets (n, b) from the ideal helix point B [m].
        kinematics: (B, 4) orbital rate w_B of the ball along the thread relative to the screw
            [rad/s] (ignored when ``centre_velocity`` is given) and ball angular velocity
            relative to the screw (t, n, b) [rad/s].
        nut_offset: (B,) b-offset e of the nut groove of each ball's nut [m].
        gravity_frenet: (B, 3) gravitational acceleration in Frenet components [m/s^2].
        centre_velocity: (B, 3) velocity of each ball centre relative to the screw, Frenet
            components [m/s].
        nut_slide: (B,) axial velocity of each ball's nut relative to the screw's thread, i.e.
            beyond the helical motion of rate -screw speed [m/s] (0 in a steady state).
        approach_offset: (B, 4) added to each contact's approach [m]: a defect of the sphere
            (radius change, on all its contacts) or of the raceway (a spall, negative where
            the groove is hollowed), see models/faults.py.
    """
    cfg = scene.config
    geom = scene.geometry
    r_b, r_s, r_m = geom.ball_radius, geom.groove_radius, geom.pitch_radius
    lead_rate = geom.lead / (2.0 * math.pi)
    zhat = geometry.axis_direction(geom.helix_angle)
    that = np.array([1.0, 0.0, 0.0])

    centres = geometry.half_groove_centres(geom, nut_offset)
    approach, normal_nb, angle = geometry.contact_geometry(ball_nb, centres, r_b, r_s)
    if approach_offset is not None:
        approach = approach + np.asarray(approach_offset, dtype=np.float64)
    active = geometry.contact_exists(
        approach, angle, geom.inner_containment_angle, geom.outer_containment_angle
    )
    delta = np.where(active, approach, 0.0)
    k_roll, k_trans = geometry.principal_curvatures(geom, angle, np.arange(4))
    radius_x, radius_y = geometry.reduced_radii(r_b, k_roll, k_trans)
    hc = hertz.contact_from_approach(delta, radius_x, radius_y, scene.e_star)

    def helical(rate: FloatArray | float, r: FloatArray) -> FloatArray:
        return np.asarray(np.asarray(rate)[..., None] * (cross(zhat, r) + lead_rate * zhat))

    zeros = np.zeros(normal_nb.shape[:-1])
    d_plane = np.stack([zeros, normal_nb[..., 0], normal_nb[..., 1]], axis=-1)  # (B, 4, 3)
    r_ball = np.stack(
        [np.zeros(len(ball_nb)), ball_nb[:, 0] - r_m, ball_nb[:, 1]], axis=-1
    )  # ball centre from the axis, (B, 3)
    arm_length = r_b - scene.deformation_ball_share * delta
    # Both grooves are helicoids of the same lead, tangent to the helical field V(r) at every
    # point: the true normal d at the contact point F + a d must satisfy d . V(F + a d) = 0.
    # Since d . (z x d) = 0, that is d . V(F) = 0: the normal-plane normal with V(F) projected
    # out (a t-component of order (offset / r_m) sin l). Without it the normal force would do
    # spurious work and the power balance would not close (docs/model.md, D12).
    field = helical(np.ones(zeros.shape), np.broadcast_to(r_ball[:, None, :], d_plane.shape))
    d = d_plane - (dot(d_plane, field) / dot(field, field))[..., None] * field
    d, _ = unit(d)
    arm = arm_length[..., None] * d  # F -> contact point
    r_point = r_ball[:, None, :] + arm

    dynamic = centre_velocity is not None
    omega = kinematics[:, 1:4]
    w_nut = -scene.screw_speed
    nut = geometry.IS_NUT[None, :, None]
    if centre_velocity is None:
        w_ball = kinematics[:, 0]
        v_centre = helical(w_ball, r_ball)  # (B, 3)
    else:
        v_centre = np.asarray(centre_velocity, dtype=np.float64)
        # Progression rate along the thread: the contact points follow the centre's t-motion.
        w_ball = v_centre[:, 0] / helical(np.ones(len(ball_nb)), r_ball)[:, 0]
    slide = np.zeros(len(ball_nb)) if nut_slide is None else np.asarray(nut_slide)
    v_ball_point = v_centre[:, None, :] + cross(omega[:, None, :], arm)
    v_nut = helical(np.full(r_point.shape[:-1], w_nut), r_point) + slide[:, None, None] * zhat
    v_groove = np.where(nut, v_nut, 0.0)
    v_contact = helical(np.broadcast_to(w_ball[:, None], r_point.shape[:-1]), r_point)
    # Eq. 18 with the saturated damping of Eq. 19; the approach rate is zero in a steady state.
    approach_rate = dot(v_centre[:, None, :] - v_groove, d)
    f_n = hertz.normal_force(delta, approach_rate, hc.stiffness, cfg.contact.damping_coefficient)
    rel = v_ball_point - v_groove
    slip_vec = rel - dot(rel, d)[..., None] * d
    slip_dir, slip = unit(slip_vec)
    u1 = dot(v_ball_point - v_contact, that)
    u2 = dot(v_groove - v_contact, that)
    entrain = 0.5 * (u1 + u2)
    srr = np.abs(u1 - u2) / film.smoothed_speed(entrain)
    e_dir = rolling.smoothed_sign(entrain)[..., None] * that
    omega_groove = np.where(nut, w_nut * zhat, 0.0)
    omega_rel = omega[:, None, :] - omega_groove
    spin = dot(omega_rel, d)
    roll_vec = omega_rel - spin[..., None] * d
    roll_dir, roll = unit(roll_vec)
    # MER and MC oppose the rolling with a magnitude that does not vanish with it: their
    # direction factor goes through 0 smoothly at the rolling speed r_b roll (D16).
    roll_share = rolling.smoothed_sign(r_b * roll)

    # Lubrication (Eqs. 26-33, 37-38).
    lub = cfg.lubricant
    h_iso = film.film_thickness_central_isothermal(
        f_n,
        entrain,
        scene.viscosity_atm,
        radius_x,
        radius_y,
        scene.e_reduced,
        lub.pressure_viscosity_coefficient,
    )
    l_th = film.thermal_loading_parameter(
        scene.viscosity_atm,
        lub.viscosity_temperature_coefficient,
        entrain,
        lub.thermal_conductivity,
    )
    c_th = film.thermal_reduction_factor(hc.max_pressure, scene.e_reduced, l_th, srr)
    h_tot = film.film_thickness_total(c_th, h_iso, lub.residual_layer)
    tallian = film.tallian_parameter(h_tot, cfg.composite_roughness)
    share = traction.load_share_asperities(tallian)

    # Sliding friction at the centre slip, and the spin sliding (Eqs. 34-36, 45).
    args = (f_n, hc.area, hc.mean_pressure, h_tot, share)
    lub_c, dry_c, _ = sliding_friction(scene, slip, *args)
    f_centre = lub_c + dry_c
    semi_major = np.maximum(hc.semi_axis_x, hc.semi_axis_y)
    semi_minor = np.minimum(hc.semi_axis_x, hc.semi_axis_y)
    v_spin = SPIN_SLIDING_FACTOR * semi_major * np.abs(spin)
    lub_s, dry_s, _ = sliding_friction(scene, v_spin, *args)
    ellipticity = semi_major / np.maximum(semi_minor, 1e-300)
    mp = rolling.spin_moment(rolling.spin_moment_factor(ellipticity), semi_major, lub_s + dry_s)
    lub_m, dry_m, tau = sliding_friction(scene, slip + v_spin, *args)
    # mu_s = F_t / F_n means nothing on an unloaded contact (a released one keeps its Hertz
    # area, so F_t stays finite while F_n -> 0): 0 below the film's minimum load (D15).
    loaded = f_n > film.FILM_MIN_LOAD
    mu_s = np.where(loaded, (lub_m + dry_m) / np.where(loaded, f_n, 1.0), 0.0)
    law = cfg.contact
    mer = rolling.hysteresis_moment(
        f_n, r_b, radius_y / radius_x, mu_s, max(law.dry_friction_coefficient, 1e-6)
    )
    mc = rolling.curvature_moment(f_n, hc.semi_axis_y, scene.surface_radius, mu_s)
    fr = rolling.rolling_resistance_force(
        f_n, entrain, scene.viscosity_atm, radius_x, radius_y, scene.e_reduced
    )
    fp = rolling.pressure_rolling_force(fr, radius_x, r_b)

    # Forces and moments on the ball (Eqs. 46-47) and their reactions on the grooves (48-49).
    # FP opposes the translation of the ball centre relative to the groove (paper 2.4). That
    # relative velocity couples two points (centre, groove at P), so it is taken in the inertial
    # frame, where the screw frame's rotation adds screw_speed z x (r_F - r_P) (D13).
    rel_centre = (
        v_centre[:, None, :]
        - v_groove
        + scene.screw_speed * cross(np.broadcast_to(zhat, arm.shape), -arm)
    )
    fp_dir = -rolling.smoothed_sign(dot(rel_centre, that))[..., None] * that
    contact_on_ball = -f_n[..., None] * d - f_centre[..., None] * slip_dir - fr[..., None] * e_dir
    pressure_on_ball = fp[..., None] * fp_dir  # acts at the ball centre
    free_moment = (
        -((mer + mc) * roll_share)[..., None] * roll_dir - (mp * np.sign(spin))[..., None] * d
    )
    moment_contacts = cross(arm, contact_on_ball) + free_moment
    groove_force = -(contact_on_ball + pressure_on_ball)
    groove_moment = cross(r_point, groove_force) - free_moment
    groove_moment_z = dot(groove_moment, zhat)

    force = (contact_on_ball + pressure_on_ball).sum(axis=1)
    moment = moment_contacts.sum(axis=1)
    if not dynamic:
        orbit_rate = scene.screw_speed + w_ball  # absolute rate of the ball's Frenet frame
        # Centrifugal force on the orbiting centre: m Omega^2 times its distance from the axis.
        r_perp = r_ball - dot(r_ball, zhat)[:, None] * zhat
        inertial = (scene.ball_mass * orbit_rate**2)[:, None] * r_perp
        force = force + scene.ball_mass * gravity_frenet + inertial
        omega_abs = omega + scene.screw_speed * zhat
        gyro = orbit_rate[:, None] * cross(
            np.broadcast_to(zhat, omega_abs.shape), scene.ball_inertia * omega_abs
        )
        moment = moment - gyro

    # Dissipated power of each mechanism. Friction, MER, MC and MP dissipate by construction;
    # FP opposes the centre's motion relative to the groove, so it does too. The FR pair (on
    # ball and groove at the same point) returns power only when the ball overruns the groove.
    dissipation = {
        "lubricant_shear": lub_c * slip,
        "dry_contact": dry_c * slip,
        "rolling_resistance": -fp * dot(fp_dir, rel_centre) + fr * dot(e_dir, slip_vec),
        "hysteresis": mer * roll_share * roll,
        "curvature": mc * roll_share * roll,
        "spin": mp * np.abs(spin),
        "normal_damping": np.where(active, (f_n - hc.stiffness * delta**1.5) * approach_rate, 0.0),
    }
    return ContactEvaluation(
        force=force,
        moment=moment,
        groove_force=groove_force,
        groove_moment_z=groove_moment_z,
        active=active,
        approach=approach,
        contact_angle=angle,
        hertz=hc,
        film_total=np.where(active, h_tot, 0.0),
        tallian=np.where(active, tallian, 0.0),
        load_share=np.where(active, share, 0.0),
        slip=np.where(active, slip, 0.0),
        spin=spin,
        roll=roll,
        entrainment=entrain,
        friction_lubricant=lub_c,
        friction_dry=dry_c,
        shear_stress=np.where(active, tau, 0.0),
        sliding_coefficient=mu_s,
        dissipation=dissipation,
    )
