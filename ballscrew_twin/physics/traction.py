"""Sliding friction of a lubricated contact in mixed lubrication (Eqs. 34-37).

F_t = tau A (1 - f(Lambda)) + f(Lambda) mu_dry F_n, with the lubricant shear tau from the
Eyring law at the Couette shear rate |v_slip| / h_Tc, capped by the limiting shear stress
tau_lim = tau_L + xi p, and the dry part made speed dependent (docs/model.md, D6 and D7).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

FloatArray = NDArray[np.float64]

EYRING_LOG_SWITCH = math.log(1e8)  # beyond, asinh(x) = ln(2x) to double precision
LOAD_SHARE_A = 1.2  # Eq. 37 numerator coefficient
LOAD_SHARE_EXP_NUM = 0.64
LOAD_SHARE_B = 0.37
LOAD_SHARE_EXP_DEN = 1.26
# g(Lambda) = 1.2 L^0.64/(1 + 0.37 L^1.26) peaks where 0.64 (1 + B L^1.26) = 1.26 B L^1.26,
# i.e. L^1.26 = 0.64 / (0.62 B); beyond it the printed law would return load to the asperities.
LOAD_SHARE_PEAK = (
    LOAD_SHARE_EXP_NUM / ((LOAD_SHARE_EXP_DEN - LOAD_SHARE_EXP_NUM) * LOAD_SHARE_B)
) ** (1.0 / LOAD_SHARE_EXP_DEN)


def shear_rate(slip_speed: ArrayLike, film: ArrayLike) -> FloatArray:
    """Couette shear rate gamma_dot = |v_t| / h_Tc, Eq. 34 [1/s]."""
    return np.asarray(np.abs(np.asarray(slip_speed)) / np.asarray(film))


def limiting_shear_stress(tau_l: float, xi: float, pressure: ArrayLike) -> FloatArray:
    """tau_lim = tau_L + xi p [Pa] (Table A.2 parameters)."""
    return np.asarray(tau_l + xi * np.maximum(np.asarray(pressure, dtype=np.float64), 0.0))


def eyring_shear_stress(
    viscosity: ArrayLike, rate: ArrayLike, eyring_stress: float, limit: ArrayLike
) -> FloatArray:
    """Lubricant shear stress tau = min(tau_e asinh(eta gamma_dot / tau_e), tau_lim), Eq. 35 [Pa].

    The printed arcsin is the inverse hyperbolic sine of the Eyring law (an arcsin would be
    undefined beyond tau_e). The argument x = eta gamma_dot / tau_e is formed in log space and
    asinh(x) = ln(2x) used beyond x = 1e8 (relative error < 1e-16), so that the astronomically
    large piezoviscous viscosity cannot overflow; zero shear rate gives zero stress.

    Args:
        viscosity: eta(p, T) [Pa s], > 0 (may be inf).
        rate: gamma_dot [1/s], >= 0.
        eyring_stress: tau_e [Pa].
        limit: tau_lim [Pa].
    """
    eta = np.asarray(viscosity, dtype=np.float64)
    gamma = np.abs(np.asarray(rate, dtype=np.float64))
    eta, gamma = np.broadcast_arrays(eta, gamma)
    sliding = gamma > 0.0
    with np.errstate(divide="ignore"):
        log_x = np.log(eta) + np.log(np.where(sliding, gamma, 1.0)) - np.log(eyring_stress)
    large = log_x > EYRING_LOG_SWITCH
    small_x = np.exp(np.minimum(log_x, EYRING_LOG_SWITCH))
    asinh = np.where(large, log_x + np.log(2.0), np.arcsinh(small_x))
    tau = np.where(sliding, eyring_stress * asinh, 0.0)
    return np.asarray(np.minimum(tau, np.asarray(limit)))


def _load_share_fraction(tallian: FloatArray) -> FloatArray:
    """g(Lambda) = 1.2 L^0.64 / (1 + 0.37 L^1.26), the film's share in Eq. 37 [-]."""
    return np.asarray(
        LOAD_SHARE_A
        * tallian**LOAD_SHARE_EXP_NUM
        / (1.0 + LOAD_SHARE_B * tallian**LOAD_SHARE_EXP_DEN)
    )


LOAD_SHARE_PEAK_VALUE = float(_load_share_fraction(np.asarray(LOAD_SHARE_PEAK)))


def load_share_asperities(tallian: ArrayLike) -> FloatArray:
    """Asperity share of the normal load f(Lambda), Eq. 37 made monotone (docs/model.md, D7) [-].

    The printed f = 1 - g(L) rises again beyond the peak of g at L* ~ 2.26, and with the
    coefficient 1.2 g(L*) = 0.9943 < 1, so f never reaches 0. Here g is frozen at its peak beyond
    L* and divided by g(L*) when that is below 1: f is continuous, non-increasing, f(0) = 1 and
    f = 0 for L >= L* (full film).
    """
    lam = np.maximum(np.asarray(tallian, dtype=np.float64), 0.0)
    g = _load_share_fraction(np.minimum(lam, LOAD_SHARE_PEAK))
    if LOAD_SHARE_PEAK_VALUE < 1.0:
        g = g / LOAD_SHARE_PEAK_VALUE
    return np.asarray(np.clip(1.0 - g, 0.0, 1.0))


def dry_friction_factor(slip_speed: ArrayLike, regularisation_speed: float) -> FloatArray:
    """Speed dependence of the dry (asperity) friction, tanh(|v| / v_r) in [0, 1) [-].

    Section 3 of the paper: friction must be speed dependent (linear below a threshold) for the
    dynamics to stay integrable; the tanh has slope 1/v_r at zero slip.
    """
    return np.asarray(np.tanh(np.abs(np.asarray(slip_speed)) / regularisation_speed))


def friction_force(
    shear_stress: ArrayLike,
    area: ArrayLike,
    load_share: ArrayLike,
    dry_coefficient: float,
    dry_factor: ArrayLike,
    normal_force: ArrayLike,
) -> tuple[FloatArray, FloatArray]:
    """Sliding friction magnitude split into (lubricant, dry) parts, Eq. 36 [N].

    lubricant = tau A (1 - f), dry = f mu_dry tanh(|v|/v_r) F_n; F_t is their sum.
    """
    f = np.asarray(load_share)
    lubricant = np.asarray(shear_stress) * np.asarray(area) * (1.0 - f)
    dry = f * dry_coefficient * np.asarray(dry_factor) * np.asarray(normal_force)
    return np.asarray(lubricant), np.asarray(dry)
