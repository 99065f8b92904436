"""Viscosity and density of the lubricant as functions of pressure and temperature.

Eq. 24 (Roelands) is used in its corrected form (docs/model.md, deviation D1):

    eta(p, T) = eta_T(T) exp{ (ln eta_T(T) + 9.67) [ (1 + 5.1e-9 p)^Z - 1 ] }

which, with the Roelands temperature law for eta_T, is identical to the closed form
eta0 exp{(ln eta0 + 9.67)[((T-138)/(T0-138))^-S0 (1 + 5.1e-9 p)^Z - 1]}. Writing it through
eta_T(T), the viscosity at atmospheric pressure, lets the temperature law be switched
(Roelands / exponential / Walther) while the pressure law stays that of Roelands.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.special import gamma, gammaincc

from ..errors import ConfigError
from ..params import Lubricant

FloatArray = NDArray[np.float64]

ROELANDS_PRESSURE_SCALE = 5.1e-9  # 1/Pa, Roelands' constant p_r^-1 (p_r = 196 MPa)
ROELANDS_LN_ETA_INF = 9.67  # -ln(eta_inf / (Pa s)), eta_inf = 6.31e-5 Pa s
ROELANDS_T_INF = 138.0  # K, Roelands' temperature constant
WALTHER_SHIFT = 0.7  # cSt, ASTM D341 constant
DOWSON_HIGGINSON_A = 0.59e9  # Pa, Eq. 25
DOWSON_HIGGINSON_B = 1.34  # -, Eq. 25


def roelands_pressure_index(lub: Lubricant) -> float:
    """Z = alpha_pv / (5.1e-9 (ln eta0 + 9.67)), Eq. 24 [-] (Table A.2: 0.6658 base oil)."""
    return lub.pressure_viscosity_coefficient / (
        ROELANDS_PRESSURE_SCALE * (np.log(lub.viscosity_reference) + ROELANDS_LN_ETA_INF)
    )


def roelands_temperature_index(lub: Lubricant) -> float:
    """S0 = beta (T0 - 138) / (ln eta0 + 9.67), Eq. 24 [-] (Table A.2: 1.1422 base oil)."""
    return (
        lub.viscosity_temperature_coefficient
        * (lub.reference_temperature - ROELANDS_T_INF)
        / (np.log(lub.viscosity_reference) + ROELANDS_LN_ETA_INF)
    )


def viscosity_atmospheric(lub: Lubricant, temperature: ArrayLike) -> FloatArray:
    """Dynamic viscosity at atmospheric pressure eta_T(T) [Pa s], law chosen by the config.

    - ``roelands``: eta0 exp{(ln eta0 + 9.67)[((T-138)/(T0-138))^-S0 - 1]} (Eq. 24 at p = 0)
    - ``exponential``: eta0 exp(-beta (T - T0)) (the law beta of Table A.2 was fitted with)
    - ``walther``: ASTM D341, log10 log10(nu + 0.7) = A - B log10 T, nu in cSt, through the two
      table points, with the density of Eq. 25 at p = 0.

    Args:
        lub: lubricant parameters.
        temperature: T [K], > 138 K.
    """
    temp = np.asarray(temperature, dtype=np.float64)
    eta0 = lub.viscosity_reference
    t0 = lub.reference_temperature
    if lub.viscosity_law == "roelands":
        a = np.log(eta0) + ROELANDS_LN_ETA_INF
        theta = (temp - ROELANDS_T_INF) / (t0 - ROELANDS_T_INF)
        return np.asarray(eta0 * np.exp(a * (theta ** (-roelands_temperature_index(lub)) - 1.0)))
    if lub.viscosity_law == "exponential":
        return np.asarray(eta0 * np.exp(-lub.viscosity_temperature_coefficient * (temp - t0)))
    # Walther / ASTM D341 through (T0, nu0) and (T1, nu1).
    t1 = lub.second_temperature

    def loglog(eta: float, t: float) -> float:
        nu_cst = eta / float(density(lub, 0.0, t)) * 1e6
        return float(np.log10(np.log10(nu_cst + WALTHER_SHIFT)))

    y0, y1 = loglog(eta0, t0), loglog(lub.viscosity_second, t1)
    slope = (y1 - y0) / (np.log10(t1) - np.log10(t0))
    y = y0 + slope * (np.log10(temp) - np.log10(t0))
    nu = (10.0 ** (10.0**y) - WALTHER_SHIFT) * 1e-6
    return np.asarray(nu * density(lub, 0.0, temp))


def viscosity(lub: Lubricant, pressure: ArrayLike, temperature: ArrayLike) -> FloatArray:
    """Dynamic viscosity eta(p, T) [Pa s], Roelands pressure law (Eq. 24, corrected form).

    Args:
        lub: lubricant parameters.
        pressure: p [Pa], negative values are treated as 0.
        temperature: T [K].
    """
    eta_t = viscosity_atmospheric(lub, temperature)
    p = np.maximum(np.asarray(pressure, dtype=np.float64), 0.0)
    z = roelands_pressure_index(lub)
    exponent = (np.log(eta_t) + ROELANDS_LN_ETA_INF) * (
        (1.0 + ROELANDS_PRESSURE_SCALE * p) ** z - 1.0
    )
    return np.asarray(eta_t * np.exp(exponent))


def film_pressure_viscosity(
    lub: Lubricant, viscosity_atm: ArrayLike, definition: str = "initial"
) -> FloatArray:
    """Pressure-viscosity coefficient implied by the Roelands pressure law at eta_T [1/Pa].

    Not used by the shipped model, whose film takes the constant ``alpha_pv`` of the parameter
    file (docs/model.md, "Against the paper: open gaps, measured"); this is the opt-in
    alternative the gap study measures. With A = ln eta_T + 9.67 and c = 5.1e-9 1/Pa:

    - ``initial``: the slope d ln eta / dp at p = 0, alpha = c Z A.
    - ``asymptotic``: the reciprocal asymptotic isoviscous pressure (Blok), alpha* =
      [integral_0^inf eta(0)/eta(p) dp]^-1 = c Z A^(1/Z) e^(-A) / Gamma(1/Z, A), the closed
      form of the integral with x = 1 + c p and s = A x^Z (upper incomplete gamma function).

    Both reproduce ``alpha_pv`` only where eta_T = eta_0 (``initial``), since Z is defined from it.

    Args:
        lub: lubricant parameters (Z from alpha_pv and eta_0).
        viscosity_atm: eta_T, viscosity at atmospheric pressure and the oil temperature [Pa s].
        definition: ``initial`` or ``asymptotic``.
    """
    z = roelands_pressure_index(lub)
    a = np.log(np.asarray(viscosity_atm, dtype=np.float64)) + ROELANDS_LN_ETA_INF
    if definition == "initial":
        return np.asarray(ROELANDS_PRESSURE_SCALE * z * a)
    if definition == "asymptotic":
        upper_gamma = gammaincc(1.0 / z, a) * gamma(1.0 / z)
        return np.asarray(ROELANDS_PRESSURE_SCALE * z * a ** (1.0 / z) * np.exp(-a) / upper_gamma)
    raise ConfigError(f"definition = {definition!r} must be initial or asymptotic")


def density(lub: Lubricant, pressure: ArrayLike, temperature: ArrayLike) -> FloatArray:
    """Density rho(p, T) [kg/m^3], Dowson-Higginson, Eq. 25.

    rho = rho0 (0.59e9 + 1.34 p) / (0.59e9 + p) + alpha_rho (T0 - T); alpha_rho is additive, in
    kg m^-3 K^-1 (docs/model.md, deviation D3).

    Args:
        lub: lubricant parameters.
        pressure: p [Pa], negative values are treated as 0.
        temperature: T [K].
    """
    p = np.maximum(np.asarray(pressure, dtype=np.float64), 0.0)
    temp = np.asarray(temperature, dtype=np.float64)
    compress = (DOWSON_HIGGINSON_A + DOWSON_HIGGINSON_B * p) / (DOWSON_HIGGINSON_A + p)
    return np.asarray(
        lub.density_reference * compress
        + lub.density_temperature_coefficient * (lub.reference_temperature - temp)
    )
