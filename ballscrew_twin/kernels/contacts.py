"""Compiled contact laws: scalar loops over spheres and half grooves (numba).

This is the compiled twin of :func:`ballscrew_twin.models.contact_forces.evaluate_contacts`: same
inputs, same :class:`~ballscrew_twin.models.contact_forces.ContactEvaluation`, same laws and the
same order of floating-point operations wherever it matters, so the two agree to rounding
(test/kernels/test_contacts_kernel.py checks <= 1e-9 relative). The readable numpy reference stays
the definition of the model; read it and docs/model.md first. Equation numbers are the paper's
(Bertolino et al. 2021), deviations D1-D13 those of docs/model.md. Everything is SI: m, N, Pa, s,
rad, K.

Structure:

- one scalar ``@njit(inline="always")`` helper per law (Hertz, viscosity, film, Gupta factor,
  load share, Eyring friction, FR/FP, MER, MC, MP), each mirroring its numpy counterpart in
  :mod:`ballscrew_twin.physics`;
- :func:`contacts_kernel`, the ``@njit(cache=True)`` loop over B spheres x 4 half grooves. The
  scene enters as plain floats and one int (:func:`scene_arrays` flattens a ``ContactScene``).
  Laws are evaluated only for active contacts: an inactive contact has delta = 0, F_n = 0 and a
  zero contact area, so every force, moment and dissipation of the reference is exactly zero
  there, and the state arrays the reference masks with ``active`` are zero too;
- :func:`evaluate_contacts_compiled`, the drop-in replacement of ``evaluate_contacts``;
- for the dynamic model, whose positions stay fixed over the evaluations of a time step:
  :func:`contacts_statics_kernel` (the velocity-independent part of every contact,
  :func:`contact_statics`, once per step) and :func:`contacts_kinetics_kernel` (the rest,
  :func:`contact_kinetics`, at each velocity), together ``contacts_kernel``'s dynamic path bit
  for bit (:func:`contact_law` is the same two halves composed).

The kernel returns two arrays: active (B, 4) and one stacked (N_ROWS, B, 4) buffer holding every
per-contact quantity (row ``CONTACT_FIELDS.index(name)``, constants ``F_APPROACH`` ... name the
rows), the groove forces and the balls' forces and moments; the wrapper hands out views of it.

The law constants below are copies of those of the physics modules (numba freezes globals into
the cached machine code, so they are kept here, in the file whose change invalidates the cache);
the test checks that they equal the reference's.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

from ..params import ScrewGeometry
from ..physics.contact_types import ContactEvaluation, ContactScene
from ..physics.hertz import HertzContact

FloatArray = NDArray[np.float64]

# ----------------------------------------------------------------------------- law constants
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

# models/contact_forces.py (D11)
SPIN_SLIDING_FACTOR = 4.0 / (3.0 * math.pi)

# ----------------------------------------------------------------------------- output layout
CONTACT_FIELDS = (
    "approach",  # m, raw rigid-body approach (negative when apart)
    "contact_angle",  # rad
    "normal_force",  # N, K_H delta^1.5 (0 when inactive)
    "semi_axis_x",  # m
    "semi_axis_y",  # m
    "hertz_approach",  # m, HertzContact.approach (delta recomputed from b)
    "max_pressure",  # Pa
    "mean_pressure",  # Pa
    "area",  # m^2
    "stiffness",  # N m^-1.5
    "film_total",  # m
    "tallian",  # -
    "load_share",  # -
    "slip",  # m/s
    "spin",  # rad/s
    "roll",  # rad/s
    "entrainment",  # m/s
    "friction_lubricant",  # N
    "friction_dry",  # N
    "shear_stress",  # Pa
    "sliding_coefficient",  # -
    "groove_moment_z",  # N m
    "lubricant_shear",  # W, dissipation rows in models.base.DISSIPATION_KEYS order from here
    "dry_contact",  # W
    "rolling_resistance",  # W
    "hysteresis",  # W
    "curvature",  # W
    "spin_dissipation",  # W (key "spin" of ContactEvaluation.dissipation)
    "normal_damping",  # W, hysteresis damping of Eqs. 18-19 (zero in a steady state)
)
N_FIELDS = len(CONTACT_FIELDS)
(
    F_APPROACH,
    F_ANGLE,
    F_NORMAL_FORCE,
    F_SEMI_X,
    F_SEMI_Y,
    F_HERTZ_APPROACH,
    F_MAX_PRESSURE,
    F_MEAN_PRESSURE,
    F_AREA,
    F_STIFFNESS,
    F_FILM,
    F_TALLIAN,
    F_LOAD_SHARE,
    F_SLIP,
    F_SPIN,
    F_ROLL,
    F_ENTRAINMENT,
    F_FRICTION_LUB,
    F_FRICTION_DRY,
    F_SHEAR_STRESS,
    F_MU_S,
    F_GROOVE_MZ,
    F_DISS_LUBRICANT,
    F_DISS_DRY,
    F_DISS_ROLLING,
    F_DISS_HYSTERESIS,
    F_DISS_CURVATURE,
    F_DISS_SPIN,
    F_DISS_DAMPING,
) = range(N_FIELDS)
# Rows after the per-contact fields: groove force (t, n, b) per contact, then the sphere's force
# and moment (t, n, b) stored in column 0 of the contact axis (the other columns stay 0).
R_GROOVE_FORCE = N_FIELDS
R_FORCE = N_FIELDS + 3
R_MOMENT = N_FIELDS + 6
N_ROWS = N_FIELDS + 9

# Half grooves S1, S2, N1, N2 (physics/geometry.py).
SIDE_N = (1.0, 1.0, -1.0, -1.0)
SIDE_B = (-1.0, 1.0, -1.0, 1.0)
IS_NUT = (False, False, True, True)


# ----------------------------------------------------------------------------- 3-vectors
@njit(inline="always")
def _cross(a, b):
    """a x b of two 3-tuples, term order of numpy.cross."""
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


@njit(inline="always")
def _dot(a, b):
    """a . b of two 3-tuples."""
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@njit(inline="always")
def _add(a, b):
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


@njit(inline="always")
def _sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


@njit(inline="always")
def _scale(s, a):
    """s a, scalar times 3-tuple."""
    return (s * a[0], s * a[1], s * a[2])


@njit(inline="always")
def _unit(v):
    """(v / max(|v|, 1e-300), |v|): the zero vector maps to itself with norm 0."""
    norm = math.sqrt(_dot(v, v))
    safe = max(norm, 1e-300)
    return (v[0] / safe, v[1] / safe, v[2] / safe), norm


@njit(inline="always")
def _helical(rate, zhat, lead_rate, r):
    """Velocity of point r [m] in a helical motion of rate ``rate`` [rad/s] about z, lead
    2 pi ``lead_rate`` [m]: rate (z x r + p/(2 pi) z) [m/s] (module docstring of the reference).
    """
    return _scale(rate, _add(_cross(zhat, r), _scale(lead_rate, zhat)))


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
# The dynamic model evaluates the contacts of one time step several times at the same positions
# (Newton iterations, Jacobian columns): contacts_statics_kernel keeps what does not depend on
# the velocities, per contact, in one float64 row of N_STATICS values: contact_geometry's
# (d_n, d_b, approach, angle, active as 0/1), then contact_statics' in its order (the three
# vectors d, arm and contact point as three values each); contacts_kinetics_kernel finishes the
# evaluation from it. Together they are contacts_kernel's dynamic path, bit for bit.
N_STATICS = 30


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
    """The velocity-independent part of every contact (layout above), written to ``statics``
    (B, 4, N_STATICS).

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
