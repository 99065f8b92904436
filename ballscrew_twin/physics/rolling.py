"""Rolling resistance and friction moments of a ball-groove contact (Eqs. 39-45).

FR, FP: hydrodynamic rolling resistance (Olaru et al.), MER: elastic-hysteresis rolling moment
(Balan et al.), MC: curvature micro-slip moment (Heathcote), MP: spin moment. Units SI; the
unit system of MER's dimensional constant and the radius in MC are documented choices
(docs/model.md, D9 and D10).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from . import film

FloatArray = NDArray[np.float64]

MER_CONSTANT = 7.48e-7  # Eq. 43, evaluated with r_b in m, Q in N, MER in N m (D9)
MER_RADIUS_EXPONENT = 0.33
MER_LOAD_EXPONENT = 1.33
MC_CONSTANT = 0.0806  # Eq. 44


def rolling_resistance_force(
    normal_force: ArrayLike,
    mean_velocity: ArrayLike,
    viscosity_atm: ArrayLike,
    radius_x: ArrayLike,
    radius_y: ArrayLike,
    reduced_modulus: float,
) -> FloatArray:
    """Hydrodynamic rolling resistance FR, Eqs. 39-41 [N].

    FR_IVR = 2.9766 E' R_x^2 lam^-0.3316 W^(1/3) U^(2/3)
    FR_EHL = 7.5826 E' R_x^2 lam^-0.4055 W^(1/3) U^(3/4)
    FR = (FR_IVR - FR_EHL) / (1 + 0.0841 lam^0.6029 W U^-0.75) + FR_EHL

    with W = F/(E' R_x^2) and U = eta_0T |u|_e/(E' R_x) (mean velocity, smoothed: D16), which is
    what the paper's W = M L^3 (alpha E')^-3 and U = 0.5 L^4 (alpha E')^-4 reduce to;
    lam = R_x / R_y. It acts along u / |u|_e (:func:`smoothed_sign`).

    Args:
        normal_force: F_n [N].
        mean_velocity: u, entrainment speed [m/s]; sign ignored.
        viscosity_atm: eta_0T [Pa s].
        radius_x: R_x [m].
        radius_y: R_y [m].
        reduced_modulus: E' [Pa].
    """
    f = np.maximum(np.asarray(normal_force, dtype=np.float64), 0.0)
    u = film.smoothed_speed(mean_velocity)
    rx = np.asarray(radius_x, dtype=np.float64)
    lam = rx / np.asarray(radius_y, dtype=np.float64)
    active = f > film.FILM_MIN_LOAD  # a film effect: none without a film
    load = np.where(active, f, 1.0) / (reduced_modulus * rx**2)
    speed = np.asarray(viscosity_atm) * u / (reduced_modulus * rx)
    scale = reduced_modulus * rx**2 * load ** (1.0 / 3.0)
    fr_ivr = 2.9766 * scale * lam**-0.3316 * speed ** (2.0 / 3.0)
    fr_ehl = 7.5826 * scale * lam**-0.4055 * speed**0.75
    blend = 1.0 + 0.0841 * lam**0.6029 * load * speed**-0.75
    return np.asarray(np.where(active, (fr_ivr - fr_ehl) / blend + fr_ehl, 0.0))


def smoothed_sign(velocity: ArrayLike) -> FloatArray:
    """v / |v|_e, the direction factor of FR (v = u, the entrainment) and FP (v = the centre's
    velocity relative to the groove) [-] (D16): sign(v) where |v| >> u_e, through 0 smoothly, so
    that FR and FP, finite at u = 0 once smoothed, change direction continuously.

    Args:
        velocity: v [m/s].
    """
    v = np.asarray(velocity, dtype=np.float64)
    return np.asarray(v / film.smoothed_speed(v))


def pressure_rolling_force(
    rolling_force: ArrayLike, radius_x: ArrayLike, ball_radius: float
) -> FloatArray:
    """Inlet-pressure force on the ball centre FP = 2 FR R_x / (R_x + r_b), Eq. 42 [N]."""
    rx = np.asarray(radius_x, dtype=np.float64)
    return np.asarray(2.0 * np.asarray(rolling_force) * rx / (rx + ball_radius))


def hysteresis_moment(
    normal_force: ArrayLike,
    ball_radius: float,
    radius_ratio: ArrayLike,
    sliding_coefficient: ArrayLike,
    dry_coefficient: float,
) -> FloatArray:
    """Elastic-hysteresis rolling moment MER, Eq. 43 [N m].

    MER = 7.48e-7 r_b^0.33 F^1.33 [1 - 3.519e-3 (R_y/R_x - 1)^0.8063] mu_s / mu_dry,
    r_b in m, F in N (D9). The bracket is clamped at 0.

    Args:
        normal_force: F_n [N].
        ball_radius: r_b [m].
        radius_ratio: lambda^-1 = R_y / R_x [-].
        sliding_coefficient: mu_s = F_t / F_n [-].
        dry_coefficient: mu_dry [-], > 0.
    """
    f = np.maximum(np.asarray(normal_force, dtype=np.float64), 0.0)
    shape = 1.0 - 3.519e-3 * np.maximum(np.asarray(radius_ratio) - 1.0, 0.0) ** 0.8063
    base = MER_CONSTANT * ball_radius**MER_RADIUS_EXPONENT * f**MER_LOAD_EXPONENT
    return np.asarray(
        base * np.maximum(shape, 0.0) * np.asarray(sliding_coefficient) / dry_coefficient
    )


def deformed_surface_radius(ball_radius: float, groove_radius: float) -> float:
    """Deformed contact-surface radius across the rolling direction, 2 r_b r_s/(r_b + r_s) [m].

    Used in MC instead of the printed 2 R_y (docs/model.md, D10).
    """
    return 2.0 * ball_radius * groove_radius / (ball_radius + groove_radius)


def curvature_moment(
    normal_force: ArrayLike,
    semi_axis_y: ArrayLike,
    surface_radius: float,
    sliding_coefficient: ArrayLike,
) -> FloatArray:
    """Curvature (Heathcote) micro-slip moment MC = 0.0806 mu_s F a_y^2 / R_c, Eq. 44 (D10) [N m].

    Args:
        normal_force: F_n [N].
        semi_axis_y: a_y, transverse (major) semi-axis [m].
        surface_radius: R_c, deformed contact-surface radius [m].
        sliding_coefficient: mu_s [-].
    """
    return np.asarray(
        MC_CONSTANT
        * np.asarray(sliding_coefficient)
        * np.maximum(np.asarray(normal_force), 0.0)
        * np.asarray(semi_axis_y) ** 2
        / surface_radius
    )


def spin_moment_factor(ellipticity: ArrayLike) -> FloatArray:
    """Bracket of Eq. 45: 3/8 + (3 pi/16 - 3/8) k^(-0.945 - 0.016 ln k), k = a_major/a_minor >= 1.

    Limits: circle (k = 1) 3 pi / 16, thin ellipse (k -> inf) 3/8.
    """
    k = np.maximum(np.asarray(ellipticity, dtype=np.float64), 1.0)
    return np.asarray(0.375 + (3.0 * np.pi / 16.0 - 0.375) * k ** (-0.945 - 0.016 * np.log(k)))


def spin_moment(
    spin_factor: ArrayLike, semi_axis_major: ArrayLike, spin_friction_force: ArrayLike
) -> FloatArray:
    """Spin moment MP = factor mu_s F_n a_y = factor a_y F_t(v_spin), Eq. 45 [N m].

    Args:
        spin_factor: bracket of Eq. 45 [-].
        semi_axis_major: a_y [m].
        spin_friction_force: mu_s F_n, friction the contact develops at the spin sliding
            speed [N] (D11).
    """
    return np.asarray(
        np.asarray(spin_factor) * np.asarray(semi_axis_major) * np.asarray(spin_friction_force)
    )
