"""EHL film thickness of a point contact and the Tallian parameter (Eqs. 26-33, 38).

The Moes dimensionless groups are built on the SUM velocity u_s = u1 + u2 = 2u and the reduced
modulus E' = 2 E*_Hertz, which is what Eq. 26a (h_c = R_x sqrt(2U) H) presupposes; the paper's
Eqs. 27-28 print the mean velocity u (docs/model.md, deviation D4).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

FloatArray = NDArray[np.float64]

MINIMUM_TO_CENTRAL = 0.75  # h_0 / h_c, Eq. 30
#: Below this load no film is formed [N]: the rigid-isoviscous term of Eq. 26d grows as M^-2,
#: so a vanishing load (a contact being released) would give an unbounded film (docs, D15).
FILM_MIN_LOAD = 1e-6
#: Speed scale u_e of the smoothed entrainment speed |u|_e = sqrt(u^2 + u_e^2) that the film
#: laws take instead of |u| [m/s] (docs/model.md, D16): film, thermal loading, slide-to-roll
#: ratio and rolling resistance go as |u|^(0.42..0.84) with an infinite slope at u = 0, where a
#: sphere's entrainment can sit in a steady state; smoothed, the Newton residual stays
#: differentiable.
ENTRAINMENT_SMOOTHING_SPEED = 1e-4


def smoothed_speed(mean_velocity: ArrayLike) -> FloatArray:
    """Smoothed entrainment speed |u|_e = sqrt(u^2 + u_e^2) [m/s] (D16), u_e =
    ENTRAINMENT_SMOOTHING_SPEED: |u| to a relative (u_e/u)^2/2 for |u| >> u_e, u_e at u = 0,
    infinitely differentiable."""
    u = np.asarray(mean_velocity, dtype=np.float64)
    return np.asarray(np.sqrt(u * u + ENTRAINMENT_SMOOTHING_SPEED**2))


def moes_groups(
    normal_force: ArrayLike,
    sum_velocity: ArrayLike,
    viscosity_atm: ArrayLike,
    radius_x: ArrayLike,
    radius_y: ArrayLike,
    reduced_modulus: float,
    pressure_viscosity: float,
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Moes load M, material L and ellipticity lambda groups, Eqs. 27-29 (sum velocity).

    M = F/(E' R_x^2) (E' R_x / (eta0 u_s))^(3/4), L = alpha E' (E' R_x/(eta0 u_s))^(-1/4),
    lambda = R_x / R_y.

    Args:
        normal_force: F_n [N].
        sum_velocity: u_s = u1 + u2 [m/s], > 0.
        viscosity_atm: eta_0T, viscosity at atmospheric pressure and the oil temperature [Pa s].
        radius_x: R_x, reduced radius in the entrainment direction [m].
        radius_y: R_y, reduced radius across it [m].
        reduced_modulus: E' = 2 E* [Pa].
        pressure_viscosity: alpha_pv [1/Pa].
    """
    f = np.asarray(normal_force, dtype=np.float64)
    rx = np.asarray(radius_x, dtype=np.float64)
    speed_group = reduced_modulus * rx / (np.asarray(viscosity_atm) * np.asarray(sum_velocity))
    m = f / (reduced_modulus * rx**2) * speed_group**0.75
    ell = pressure_viscosity * reduced_modulus * speed_group**-0.25
    lam = rx / np.asarray(radius_y, dtype=np.float64)
    return np.asarray(m), np.asarray(ell), np.asarray(lam)


def central_film_nondimensional(m: ArrayLike, ell: ArrayLike, lam: ArrayLike) -> FloatArray:
    """Nijenbanning-Venner-Moes (1994) central film H_c for all regimes, Eq. 26a-g [-].

    H_c = {[H_RI^(3/2) + (H_EI^-4 + h00^-4)^(-3/8)]^(2s/3) + (H_RP^-8 + H_EP^-8)^(-s/8)}^(1/s)

    with the grouping of exponents of MODEL_NOTES section 1 (the only dimensionally coherent
    reading of the printed Eq. 26a).

    Args:
        m: Moes load parameter M [-].
        ell: Moes material parameter L [-].
        lam: ellipticity group lambda = R_x / R_y [-].
    """
    m = np.asarray(m, dtype=np.float64)
    ell = np.asarray(ell, dtype=np.float64)
    lam = np.asarray(lam, dtype=np.float64)
    h00 = 1.8 / lam
    h_ri = 145.0 * (1.0 + 0.796 * lam ** (14.0 / 15.0)) ** (-15.0 / 7.0) / lam / m**2
    h_rp = 1.29 * (1.0 + 0.691 * lam) ** (-2.0 / 3.0) * ell ** (2.0 / 3.0)
    shape = 1.0 + 0.006 * np.log(lam) + 0.63 * lam ** (4.0 / 7.0)
    h_ei = 3.18 * shape ** (-14.0 / 25.0) * lam ** (-1.0 / 15.0) * m ** (-2.0 / 15.0)
    h_ep = 1.48 * shape ** (-7.0 / 20.0) * lam ** (-1.0 / 24.0) * m ** (-1.0 / 12.0) * ell**0.75
    s = 1.5 * (1.0 + np.exp(-1.2 * h_ei / h_ri))
    isoviscous = (h_ri**1.5 + (h_ei**-4 + h00**-4) ** -0.375) ** (2.0 * s / 3.0)
    piezoviscous = (h_rp**-8 + h_ep**-8) ** (-s / 8.0)
    return np.asarray((isoviscous + piezoviscous) ** (1.0 / s))


def film_thickness_central_isothermal(
    normal_force: ArrayLike,
    mean_velocity: ArrayLike,
    viscosity_atm: ArrayLike,
    radius_x: ArrayLike,
    radius_y: ArrayLike,
    reduced_modulus: float,
    pressure_viscosity: float,
) -> FloatArray:
    """Isothermal central film thickness h_c [m], Eq. 26a: h_c = R_x sqrt(eta0 u_s/(E' R_x)) H_c,
    u_s = 2 |u|_e (smoothed speed, D16).

    Zero where the load is below FILM_MIN_LOAD (no film).

    Args:
        normal_force: F_n [N].
        mean_velocity: u = (u1 + u2)/2, entrainment speed (Eq. 23) [m/s]; sign ignored.
        viscosity_atm: eta_0T [Pa s].
        radius_x: R_x [m].
        radius_y: R_y [m].
        reduced_modulus: E' = 2 E* [Pa].
        pressure_viscosity: alpha_pv [1/Pa].
    """
    u_safe = 2.0 * smoothed_speed(mean_velocity)
    f = np.asarray(normal_force, dtype=np.float64)
    rx = np.asarray(radius_x, dtype=np.float64)
    active = f > FILM_MIN_LOAD
    f_safe = np.where(active, f, 1.0)
    m, ell, lam = moes_groups(
        f_safe, u_safe, viscosity_atm, rx, radius_y, reduced_modulus, pressure_viscosity
    )
    h_nd = central_film_nondimensional(m, ell, lam)
    h = rx * np.sqrt(np.asarray(viscosity_atm) * u_safe / (reduced_modulus * rx)) * h_nd
    return np.asarray(np.where(active, h, 0.0))


def thermal_loading_parameter(
    viscosity_atm: ArrayLike, beta: float, mean_velocity: ArrayLike, conductivity: float
) -> FloatArray:
    """L_th = eta_0T beta |u|_e^2 / k_h, Eq. 32 [-] (u: mean entrainment speed, Gupta et al.
    1992; |u|_e the smoothed speed, D16).

    Args:
        viscosity_atm: eta_0T [Pa s].
        beta: temperature-viscosity coefficient [1/K].
        mean_velocity: u [m/s].
        conductivity: k_h [W/(m K)].
    """
    u = smoothed_speed(mean_velocity)
    return np.asarray(np.asarray(viscosity_atm) * beta * u**2 / conductivity)


def thermal_reduction_factor(
    max_pressure: ArrayLike,
    reduced_modulus: float,
    thermal_loading: ArrayLike,
    slide_to_roll: ArrayLike,
) -> FloatArray:
    """Inlet-shear-heating film reduction C = h_thermal / h_isothermal, Eq. 31, clamped to [0, 1].

    C = (1 - 13.2 (p_h/E') L_th^0.42) / (1 + 0.213 (1 + 2.23 SRR^0.83) L_th^0.64)

    The numerator goes negative at large L_th; the clamp keeps the film non-negative
    (docs/model.md, deviation D5).

    Args:
        max_pressure: p_h [Pa].
        reduced_modulus: E' [Pa].
        thermal_loading: L_th [-].
        slide_to_roll: SRR = |u1 - u2| / |u|_e [-] (D16).
    """
    lth = np.maximum(np.asarray(thermal_loading, dtype=np.float64), 0.0)
    srr = np.abs(np.asarray(slide_to_roll, dtype=np.float64))
    num = 1.0 - 13.2 * np.asarray(max_pressure) / reduced_modulus * lth**0.42
    den = 1.0 + 0.213 * (1.0 + 2.23 * srr**0.83) * lth**0.64
    return np.asarray(np.clip(num / den, 0.0, 1.0))


def film_thickness_total(
    thermal_factor: ArrayLike, central_isothermal: ArrayLike, residual_layer: float
) -> FloatArray:
    """Total central film h_Tc = C h_c + h_R, Eq. 33 [m]."""
    return np.asarray(np.asarray(thermal_factor) * np.asarray(central_isothermal) + residual_layer)


def tallian_parameter(film: ArrayLike, composite_roughness: float) -> FloatArray:
    """Lambda = h_Tc / sqrt(sigma_1^2 + sigma_2^2), Eq. 38 [-]; infinite for smooth surfaces."""
    h = np.asarray(film, dtype=np.float64)
    if composite_roughness <= 0.0:
        return np.full_like(h, np.inf)
    return np.asarray(h / composite_roughness)
