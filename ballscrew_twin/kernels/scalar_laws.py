"""Compiled scalar contact laws: one ``@njit(inline="always")`` helper per physical law.

Hertz ellipse and stiffness, viscosity (Roelands, exponential, Walther) and its pressure
dependence, central film, Gupta inlet heating, asperity load share, Eyring friction, rolling
resistance FR, the moments MER, MC and the spin-moment factor: each mirrors its numpy
counterpart in :mod:`ballscrew_twin.physics` with the same order of floating-point operations
(test/kernels/test_contacts_kernel.py). Everything is SI: m, N, Pa, s, rad, K.

The law constants below are copies of those of the physics modules (numba freezes globals into
the cached machine code, so they are kept in a kernel file, whose change invalidates the cache
of every kernel calling it: :mod:`ballscrew_twin.kernels.cache_stamp`); the test checks that
they equal the reference's.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

# physics/lubricant.py (Eqs. 24-25)
ROELANDS_PRESSURE_SCALE = 5.1e-9  # 1/Pa
FILM_MIN_LOAD = 1e-6  # N, film.FILM_MIN_LOAD
ROELANDS_LN_ETA_INF = 9.67  # -ln(eta_inf / Pa s)
ROELANDS_T_INF = 138.0  # K
WALTHER_SHIFT = 0.7  # cSt
DOWSON_HIGGINSON_A = 0.59e9  # Pa
DOWSON_HIGGINSON_B = 1.34  # -
VISCOSITY_LAWS = ("roelands", "exponential", "walther")  # law code = index
LAW_ROELANDS, LAW_EXPONENTIAL, LAW_WALTHER = 0, 1, 2

# physics/hertz.py (Antoine et al. 2006; Abramowitz & Stegun 17.3.34, 17.3.36)
ANTOINE_NUMERATOR = (1.0, 0.40227436, 3.7491752e-2, 7.4855761e-4, 2.1667028e-6)
ANTOINE_DENOMINATOR = (1.0, 0.42678878, 4.2605401e-2, 9.0786922e-4, 2.7868927e-6)
K_POLY = (1.38629436112, 0.09666344259, 0.03590092383, 0.03742563713, 0.01451196212)
K_LOG_POLY = (0.5, 0.12498593597, 0.06880248576, 0.03328355346, 0.00441787012)
E_POLY = (1.0, 0.44325141463, 0.06260601220, 0.04757383546, 0.01736506451)
E_LOG_POLY = (0.0, 0.24998368310, 0.09200180037, 0.04069697526, 0.00526449639)

# physics/film.py (D15, D16; Eq. 30's 0.75 is not needed)
ENTRAINMENT_SMOOTHING_SPEED = 1e-4  # m/s, film.ENTRAINMENT_SMOOTHING_SPEED

# physics/traction.py (Eq. 37, D7)
LOAD_SHARE_A = 1.2
LOAD_SHARE_EXP_NUM = 0.64
LOAD_SHARE_B = 0.37
LOAD_SHARE_EXP_DEN = 1.26
LOAD_SHARE_PEAK = (
    LOAD_SHARE_EXP_NUM / ((LOAD_SHARE_EXP_DEN - LOAD_SHARE_EXP_NUM) * LOAD_SHARE_B)
) ** (1.0 / LOAD_SHARE_EXP_DEN)
LOAD_SHARE_PEAK_VALUE = (
    LOAD_SHARE_A
    * LOAD_SHARE_PEAK**LOAD_SHARE_EXP_NUM
    / (1.0 + LOAD_SHARE_B * LOAD_SHARE_PEAK**LOAD_SHARE_EXP_DEN)
)

# physics/rolling.py (Eqs. 43-44, D9)
MER_CONSTANT = 7.48e-7
MER_RADIUS_EXPONENT = 0.33
MER_LOAD_EXPONENT = 1.33
MC_CONSTANT = 0.0806

LN_10 = math.log(10.0)


# ----------------------------------------------------------------------------- Hertz (2.2)
@njit(inline="always")
def _horner(x, c):
    """c0 + c1 x + ... + c4 x^4 of a 5-tuple by Horner's rule (hertz._polyval's order)."""
    return (((c[4] * x + c[3]) * x + c[2]) * x + c[1]) * x + c[0]


@njit(inline="always")
def ellipse_shape(r_x, r_y):
    """Load-independent ellipse of a contact with reduced radii r_x, r_y [m] (hertz.py).

    k = r^p, p = (2/3) N(q)/D(q), q = (log10 r)^2, r = max/min radius (Antoine et al. 2006);
    K(m), E(m), m = 1 - 1/k^2 (Abramowitz & Stegun 17.3.34, 17.3.36); A + B = (1/R_x + 1/R_y)/2.

    Returns:
        (k [-], K(m) [-], E(m) [-], A + B [1/m]).
    """
    curvature_ratio = max(r_x, r_y) / min(r_x, r_y)
    ln_ratio = math.log(curvature_ratio)
    lg = ln_ratio / LN_10
    q = lg * lg
    exponent = (2.0 / 3.0) * (_horner(q, ANTOINE_NUMERATOR) / _horner(q, ANTOINE_DENOMINATOR))
    ratio = math.exp(exponent * ln_ratio)  # r^p
    m1 = 1.0 - (1.0 - 1.0 / (ratio * ratio))
    log_term = -math.log(m1)
    ell_k = _horner(m1, K_POLY) + log_term * _horner(m1, K_LOG_POLY)
    ell_e = _horner(m1, E_POLY) + log_term * _horner(m1, E_LOG_POLY)
    curvature_sum = 0.5 * (1.0 / r_x + 1.0 / r_y)
    return ratio, ell_k, ell_e, curvature_sum


@njit(inline="always")
def hertz_stiffness(ratio, ell_k, ell_e, curvature_sum, e_star):
    """K_H = eps(k) (4/3) E* sqrt(R_e), eps = pi k sqrt(E) / (2 K^1.5) [N m^-1.5] (Eq. 18)."""
    eccentricity = math.pi * ratio * math.sqrt(ell_e) / (2.0 * (ell_k * math.sqrt(ell_k)))
    return eccentricity * (4.0 / 3.0) * e_star / math.sqrt(curvature_sum)


@njit(inline="always")
def hertz_from_approach(delta, ratio, ell_k, ell_e, curvature_sum, e_star):
    """Hertz contact at approach delta [m] (Johnson 1985 Eqs. 4.36-4.38, hertz.py).

    b = sqrt(delta E / ((A + B) K)), a = k b, p0 = E* (A + B) b / E.

    Returns:
        (minor b [m], major a [m], approach [m], p0 [Pa], mean pressure [Pa], area [m^2]).
    """
    minor = math.sqrt(max(delta, 0.0) * ell_e / (curvature_sum * ell_k))
    major = ratio * minor
    max_pressure = e_star * curvature_sum * minor / ell_e
    approach = curvature_sum * (minor * minor) * ell_k / ell_e
    return (
        minor,
        major,
        approach,
        max_pressure,
        (2.0 / 3.0) * max_pressure,
        math.pi * major * minor,
    )


# ----------------------------------------------------------------------------- lubricant
@njit(inline="always")
def density_atmospheric(temperature, rho0, t0, alpha_rho):
    """rho(0, T) = rho0 + alpha_rho (T0 - T) [kg/m^3] (Eq. 25 at p = 0, D3)."""
    compress = (DOWSON_HIGGINSON_A + DOWSON_HIGGINSON_B * 0.0) / (DOWSON_HIGGINSON_A + 0.0)
    return rho0 * compress + alpha_rho * (t0 - temperature)


@njit(inline="always")
def _walther_loglog(eta, temperature, rho0, t0, alpha_rho):
    """log10 log10(nu + 0.7), nu [cSt] of viscosity eta [Pa s] at T [K] (ASTM D341)."""
    nu_cst = eta / density_atmospheric(temperature, rho0, t0, alpha_rho) * 1e6
    return math.log10(math.log10(nu_cst + WALTHER_SHIFT))


@njit(inline="always")
def viscosity_atmospheric(law, temperature, eta0, t0, t1, eta1, rho0, alpha_rho, beta):
    """eta_T(T) [Pa s] at atmospheric pressure; law code 0/1/2 (lubricant.py, D2).

    0 Roelands: eta0 exp{(ln eta0 + 9.67)[((T-138)/(T0-138))^-S0 - 1]} (Eq. 24 at p = 0),
    S0 = beta (T0 - 138) / (ln eta0 + 9.67); 1 exponential: eta0 exp(-beta (T - T0));
    2 Walther (ASTM D341) through (T0, eta0) and (T1, eta1) with the density of Eq. 25.
    """
    if law == LAW_ROELANDS:
        a = math.log(eta0) + ROELANDS_LN_ETA_INF
        theta = (temperature - ROELANDS_T_INF) / (t0 - ROELANDS_T_INF)
        s0 = beta * (t0 - ROELANDS_T_INF) / (math.log(eta0) + ROELANDS_LN_ETA_INF)
        return eta0 * math.exp(a * (theta ** (-s0) - 1.0))
    if law == LAW_EXPONENTIAL:
        return eta0 * math.exp(-beta * (temperature - t0))
    y0 = _walther_loglog(eta0, t0, rho0, t0, alpha_rho)
    y1 = _walther_loglog(eta1, t1, rho0, t0, alpha_rho)
    slope = (y1 - y0) / (math.log10(t1) - math.log10(t0))
    y = y0 + slope * (math.log10(temperature) - math.log10(t0))
    nu = (10.0 ** (10.0**y) - WALTHER_SHIFT) * 1e-6
    return nu * density_atmospheric(temperature, rho0, t0, alpha_rho)


@njit(inline="always")
def viscosity_pressure(eta_t, pressure, z):
    """eta(p, T) = eta_T exp{(ln eta_T + 9.67)[(1 + 5.1e-9 p)^Z - 1]} [Pa s] (Eq. 24, D1).

    eta_t: eta_T(T) [Pa s]; pressure: p [Pa] (negative -> 0); z: Roelands index Z [-].
    """
    p = max(pressure, 0.0)
    exponent = (math.log(eta_t) + ROELANDS_LN_ETA_INF) * (
        (1.0 + ROELANDS_PRESSURE_SCALE * p) ** z - 1.0
    )
    return eta_t * math.exp(exponent)


# ----------------------------------------------------------------------------- film (2.3)
@njit(inline="always")
def smoothed_speed(entrainment):
    """|u|_e = sqrt(u^2 + u_e^2) [m/s], the entrainment speed the film laws take (film.py, D16)."""
    return math.sqrt(entrainment * entrainment + ENTRAINMENT_SMOOTHING_SPEED**2)


@njit(inline="always")
def central_film_nondimensional(m, ell, lam):
    """Nijenbanning-Venner-Moes central film H_c(M, L, lambda) [-] (Eq. 26a-g, film.py).

    H_c = {[H_RI^(3/2) + (H_EI^-4 + h00^-4)^(-3/8)]^(2s/3) + (H_RP^-8 + H_EP^-8)^(-s/8)}^(1/s),
    h00 = 1.8/lambda, s = 1.5 (1 + exp(-1.2 H_EI/H_RI)). Fractional powers of M, L, lambda and
    the shape factor share one logarithm each (x^a = exp(a ln x)), integer ones are products.
    """
    ln_lam = math.log(lam)
    ln_m = math.log(m)
    ln_ell = math.log(ell)
    h00 = 1.8 / lam
    h_ri = 145.0 * (1.0 + 0.796 * math.exp((14.0 / 15.0) * ln_lam)) ** (-15.0 / 7.0) / lam / (m * m)
    h_rp = 1.29 * (1.0 + 0.691 * lam) ** (-2.0 / 3.0) * math.exp((2.0 / 3.0) * ln_ell)
    shape = 1.0 + 0.006 * ln_lam + 0.63 * math.exp((4.0 / 7.0) * ln_lam)
    ln_shape = math.log(shape)
    h_ei = 3.18 * math.exp(
        (-14.0 / 25.0) * ln_shape + (-1.0 / 15.0) * ln_lam + (-2.0 / 15.0) * ln_m
    )
    h_ep = 1.48 * math.exp(
        (-7.0 / 20.0) * ln_shape + (-1.0 / 24.0) * ln_lam + (-1.0 / 12.0) * ln_m + 0.75 * ln_ell
    )
    s = 1.5 * (1.0 + math.exp(-1.2 * h_ei / h_ri))
    inv_ei2 = 1.0 / (h_ei * h_ei)
    inv_002 = 1.0 / (h00 * h00)
    inv_rp4 = 1.0 / ((h_rp * h_rp) * (h_rp * h_rp))
    inv_ep4 = 1.0 / ((h_ep * h_ep) * (h_ep * h_ep))
    isoviscous = (h_ri * math.sqrt(h_ri) + (inv_ei2 * inv_ei2 + inv_002 * inv_002) ** -0.375) ** (
        2.0 * s / 3.0
    )
    piezoviscous = (inv_rp4 * inv_rp4 + inv_ep4 * inv_ep4) ** (-s / 8.0)
    return (isoviscous + piezoviscous) ** (1.0 / s)


@njit(inline="always")
def film_central_isothermal(f_n, entrainment, eta_atm, r_x, r_y, e_reduced, alpha_pv):
    """Isothermal central film h_c = R_x sqrt(eta0 u_s / (E' R_x)) H_c [m] (Eq. 26a, D4).

    Moes groups on the sum velocity u_s = 2|u|_e (Eqs. 27-29, D16): M = F/(E' R_x^2) (E' R_x /
    (eta0 u_s))^(3/4), L = alpha E' (E' R_x / (eta0 u_s))^(-1/4), lambda = R_x / R_y.
    Zero when F_n is below FILM_MIN_LOAD (film.py, D15).
    """
    if not f_n > FILM_MIN_LOAD:
        return 0.0
    u_sum = 2.0 * smoothed_speed(entrainment)
    speed_group = e_reduced * r_x / (eta_atm * u_sum)
    ln_group = math.log(speed_group)
    m = f_n / (e_reduced * (r_x * r_x)) * math.exp(0.75 * ln_group)
    ell = alpha_pv * e_reduced * math.exp(-0.25 * ln_group)
    lam = r_x / r_y
    h_nd = central_film_nondimensional(m, ell, lam)
    return r_x * math.sqrt(eta_atm * u_sum / (e_reduced * r_x)) * h_nd


@njit(inline="always")
def thermal_reduction_factor(max_pressure, e_reduced, eta_atm, beta, entrainment, k_h, srr):
    """Gupta inlet-heating factor C in [0, 1] (Eqs. 31-32, D5).

    L_th = eta0 beta |u|_e^2 / k_h (D16); C = (1 - 13.2 (p_h/E') L_th^0.42) /
    (1 + 0.213 (1 + 2.23 SRR^0.83) L_th^0.64), clamped to [0, 1].
    """
    speed = smoothed_speed(entrainment)
    lth = max(eta_atm * beta * (speed * speed) / k_h, 0.0)
    srr_abs = abs(srr)
    ln_lth = math.log(lth) if lth > 0.0 else -np.inf
    srr_pow = math.exp(0.83 * math.log(srr_abs)) if srr_abs > 0.0 else 0.0
    num = 1.0 - 13.2 * max_pressure / e_reduced * math.exp(0.42 * ln_lth)
    den = 1.0 + 0.213 * (1.0 + 2.23 * srr_pow) * math.exp(0.64 * ln_lth)
    return min(max(num / den, 0.0), 1.0)


@njit(inline="always")
def load_share_asperities(tallian):
    """Asperity share f(Lambda) of the normal load, Eq. 37 made monotone (D7) [-]."""
    lam = min(max(tallian, 0.0), LOAD_SHARE_PEAK)
    ln_lam = math.log(lam) if lam > 0.0 else -np.inf
    g = (
        LOAD_SHARE_A
        * math.exp(LOAD_SHARE_EXP_NUM * ln_lam)
        / (1.0 + LOAD_SHARE_B * math.exp(LOAD_SHARE_EXP_DEN * ln_lam))
    )
    if LOAD_SHARE_PEAK_VALUE < 1.0:
        g = g / LOAD_SHARE_PEAK_VALUE
    return min(max(1.0 - g, 0.0), 1.0)


# ----------------------------------------------------------------------------- friction (3)
@njit(inline="always")
def sliding_friction(speed, eta, limit, film_safe, area, share, f_n, tau_e, mu_dry, v_r):
    """Friction at sliding speed v [m/s], Eqs. 34-36 regularised (D6).

    F(v) = [(1 - f) A tau(sqrt(v^2 + v_r^2)) + f mu_dry F_n] tanh(|v| / v_r), with the Eyring
    stress tau = min(tau_e asinh(eta gamma / tau_e), tau_lim), gamma = sqrt(v^2 + v_r^2) / h.

    Args:
        eta: eta(p_mean, T) [Pa s]; limit: tau_lim [Pa]; film_safe: max(h_Tc, 1e-12) [m];
        area [m^2]; share: f(Lambda) [-]; f_n [N]; tau_e [Pa]; mu_dry [-]; v_r [m/s].

    Returns:
        (lubricant part [N], dry part [N], shear stress times tanh [Pa]).
    """
    rate = math.hypot(speed, v_r) / film_safe
    tau = min(tau_e * math.asinh(eta * rate / tau_e), limit)
    ramp = math.tanh(abs(speed) / v_r)
    lubricant = tau * area * (1.0 - share)
    dry = share * mu_dry * 1.0 * f_n
    return lubricant * ramp, dry * ramp, tau * ramp


@njit(inline="always")
def rolling_resistance_force(f_n, entrainment, eta_atm, r_x, r_y, e_reduced):
    """Hydrodynamic rolling resistance FR [N] (Eqs. 39-41), W = F/(E' R_x^2), U = eta0 u/(E' R_x).

    FR = (FR_IVR - FR_EHL) / (1 + 0.0841 lam^0.6029 W U^-0.75) + FR_EHL, zero without load; u
    is the smoothed speed |u|_e (D16).
    """
    f = max(f_n, 0.0)
    if not f > FILM_MIN_LOAD:  # a film effect: none without a film
        return 0.0
    u = smoothed_speed(entrainment)
    ln_lam = math.log(r_x / r_y)
    load = f / (e_reduced * (r_x * r_x))
    ln_speed = math.log(eta_atm * u / (e_reduced * r_x))
    scale = e_reduced * (r_x * r_x) * math.exp(math.log(load) / 3.0)
    fr_ivr = 2.9766 * scale * math.exp(-0.3316 * ln_lam + (2.0 / 3.0) * ln_speed)
    fr_ehl = 7.5826 * scale * math.exp(-0.4055 * ln_lam + 0.75 * ln_speed)
    blend = 1.0 + 0.0841 * load * math.exp(0.6029 * ln_lam - 0.75 * ln_speed)
    return (fr_ivr - fr_ehl) / blend + fr_ehl


@njit(inline="always")
def hysteresis_moment(f_n, ball_radius, radius_ratio, mu_s, dry_coefficient):
    """MER = 7.48e-7 r_b^0.33 F^1.33 [1 - 3.519e-3 (R_y/R_x - 1)^0.8063]_+ mu_s / mu_dry [N m]
    (Eq. 43, D9)."""
    f = max(f_n, 0.0)
    excess = max(radius_ratio - 1.0, 0.0)
    shape = 1.0 - 3.519e-3 * (math.exp(0.8063 * math.log(excess)) if excess > 0.0 else 0.0)
    load_power = math.exp(MER_LOAD_EXPONENT * math.log(f)) if f > 0.0 else 0.0
    base = MER_CONSTANT * ball_radius**MER_RADIUS_EXPONENT * load_power
    return base * max(shape, 0.0) * mu_s / dry_coefficient


@njit(inline="always")
def curvature_moment(f_n, semi_axis_y, surface_radius, mu_s):
    """MC = 0.0806 mu_s F a_y^2 / R_c [N m] (Eq. 44, D10)."""
    return MC_CONSTANT * mu_s * max(f_n, 0.0) * (semi_axis_y * semi_axis_y) / surface_radius


@njit(inline="always")
def spin_moment_factor(ellipticity):
    """3/8 + (3 pi/16 - 3/8) k^(-0.945 - 0.016 ln k), k = max(ellipticity, 1) (Eq. 45)."""
    k = max(ellipticity, 1.0)
    ln_k = math.log(k)
    return 0.375 + (3.0 * math.pi / 16.0 - 0.375) * math.exp((-0.945 - 0.016 * ln_k) * ln_k)
