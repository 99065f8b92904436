"""Contact between two neighbouring spheres (paper section 2.5), vectorised over pairs.

The same laws as the ball-groove contact: Hertz normal force with saturated damping
(Eqs. 17-19), EHL film and Tallian parameter (Eqs. 26-33, 38), lubricated sliding friction
(Eqs. 34-37, with D6), hydrodynamic rolling resistance (Eqs. 39-42) and spin moment (Eq. 45).
Both spheres are equal: the reduced radii are R_x = R_y = r_b / 2 (circular contact), and the
geometry is that of two spheres only, as the paper notes.

Vectors are (..., 3) arrays in any common frame; positions relative to any origin.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..physics import film, hertz, rolling, traction
from ..physics.contact_types import ContactScene
from .contact_forces import SPIN_SLIDING_FACTOR, dot, sliding_friction

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class SpherePairContact:
    """Result for P pairs (a, b); forces and moments act on sphere a, about its centre."""

    in_contact: NDArray[np.bool_]  # (P,)
    approach: FloatArray  # (P,) m, 2 r_b - distance
    normal_force: FloatArray  # (P,) N, >= 0
    friction_force: FloatArray  # (P,) N
    film_thickness: FloatArray  # (P,) m
    tallian_parameter: FloatArray  # (P,)
    slip_speed: FloatArray  # (P,) m/s
    force_on_a: FloatArray  # (P, 3) N; sphere b receives the opposite force
    moment_on_a: FloatArray  # (P, 3) N m about a's centre
    moment_on_b: FloatArray  # (P, 3) N m about b's centre
    dissipation: FloatArray  # (P,) W, >= 0, normal damping included
    elastic_energy: FloatArray  # (P,) J, 2/5 K delta^2.5: the potential of the elastic force


def sphere_pair_contact(
    scene: ContactScene,
    centre_a: FloatArray,
    centre_b: FloatArray,
    velocity_a: FloatArray,
    velocity_b: FloatArray,
    omega_a: FloatArray,
    omega_b: FloatArray,
) -> SpherePairContact:
    """Forces and moments between spheres a and b of each pair.

    Args:
        scene: constants of the operating point (materials, lubricant, temperature).
        centre_a, centre_b: (P, 3) centre positions [m].
        velocity_a, velocity_b: (P, 3) centre velocities [m/s].
        omega_a, omega_b: (P, 3) angular velocities [rad/s].
    """
    geom = scene.geometry
    r_b = geom.ball_radius
    cfg = scene.config
    mats = cfg.materials
    e_star = float(
        hertz.effective_modulus(
            mats.ball.young_modulus,
            mats.ball.poisson_ratio,
            mats.ball.young_modulus,
            mats.ball.poisson_ratio,
        )
    )
    separation = np.asarray(centre_b, dtype=np.float64) - np.asarray(centre_a, dtype=np.float64)
    distance = np.sqrt(dot(separation, separation))
    d = separation / np.maximum(distance, 1e-300)[:, None]  # from a towards b
    approach = 2.0 * r_b - distance
    touching = approach > 0.0
    delta = np.where(touching, approach, 0.0)
    radius = np.full_like(delta, 0.5 * r_b)
    hc = hertz.contact_from_approach(delta, radius, radius, e_star)
    rate = -dot(np.asarray(velocity_b) - np.asarray(velocity_a), d)  # d delta / dt
    f_n = hertz.normal_force(delta, rate, hc.stiffness, cfg.contact.damping_coefficient)

    arm_a = (r_b - 0.5 * delta)[:, None] * d
    arm_b = -arm_a
    surf_a = np.asarray(velocity_a) + np.cross(omega_a, arm_a)
    surf_b = np.asarray(velocity_b) + np.cross(omega_b, arm_b)
    point_velocity = 0.5 * (np.asarray(velocity_a) + np.asarray(velocity_b))
    rel = surf_a - surf_b
    slip_vec = rel - dot(rel, d)[:, None] * d
    slip = np.sqrt(dot(slip_vec, slip_vec))
    slip_dir = slip_vec / np.maximum(slip, 1e-300)[:, None]
    mean_surface = 0.5 * ((surf_a - point_velocity) + (surf_b - point_velocity))
    mean_surface = mean_surface - dot(mean_surface, d)[:, None] * d
    entrain = np.sqrt(dot(mean_surface, mean_surface))
    e_dir = mean_surface / film.smoothed_speed(entrain)[:, None]  # FR's share: D16

    lub = cfg.lubricant
    h_iso = film.film_thickness_central_isothermal(
        f_n,
        entrain,
        scene.viscosity_atm,
        radius,
        radius,
        scene.e_reduced,
        lub.pressure_viscosity_coefficient,
    )
    h_tot = film.film_thickness_total(1.0, h_iso, lub.residual_layer)
    sigma = float(np.hypot(cfg.screw.ball_roughness, cfg.screw.ball_roughness))
    tallian = film.tallian_parameter(h_tot, sigma)
    share = traction.load_share_asperities(tallian)
    args = (f_n, hc.area, hc.mean_pressure, h_tot, share)
    lub_c, dry_c, _ = sliding_friction(scene, slip, *args)
    f_t = lub_c + dry_c
    spin = dot(np.asarray(omega_a) - np.asarray(omega_b), d)
    lub_s, dry_s, _ = sliding_friction(
        scene, SPIN_SLIDING_FACTOR * hc.semi_axis_y * np.abs(spin), *args
    )
    mp = rolling.spin_moment(rolling.spin_moment_factor(1.0), hc.semi_axis_y, lub_s + dry_s)
    fr = rolling.rolling_resistance_force(
        f_n, entrain, scene.viscosity_atm, radius, radius, scene.e_reduced
    )

    # On a at the contact point: normal push (towards a), friction against the slip, FR against
    # the entrainment; b receives the opposite at the same point (no pressure couple: equal
    # spheres see the inlet pressure symmetrically).
    on_a = -f_n[:, None] * d - f_t[:, None] * slip_dir - fr[:, None] * e_dir
    spin_moment = -(mp * np.sign(spin))[:, None] * d
    moment_a = np.cross(arm_a, on_a) + spin_moment
    moment_b = np.cross(arm_b, -on_a) - spin_moment
    damping = f_n - hc.stiffness * delta**1.5  # saturated damping part of Eq. 18 [N]
    dissipation = f_t * slip + fr * dot(e_dir, slip_vec) + mp * np.abs(spin) + damping * rate
    active = touching & (f_n > 0.0)
    return SpherePairContact(
        in_contact=active,
        approach=approach,
        normal_force=np.where(active, f_n, 0.0),
        friction_force=np.where(active, f_t, 0.0),
        film_thickness=np.where(active, h_tot, 0.0),
        tallian_parameter=np.where(active, tallian, 0.0),
        slip_speed=np.where(active, slip, 0.0),
        force_on_a=np.where(active[:, None], on_a, 0.0),
        moment_on_a=np.where(active[:, None], moment_a, 0.0),
        moment_on_b=np.where(active[:, None], moment_b, 0.0),
        dissipation=np.where(active, dissipation, 0.0),
        elastic_energy=np.where(touching, 0.4 * hc.stiffness * delta**2.5, 0.0),
    )
