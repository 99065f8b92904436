"""Tests of :mod:`ballscrew_twin.physics.traction` (Eqs. 34-37) against independent oracles."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import minimize_scalar

from ballscrew_twin.physics import traction


def g_printed(lam: float) -> float:
    """Film share of Eq. 37 as printed: 1.2 L^0.64 / (1 + 0.37 L^1.26)."""
    return 1.2 * lam**0.64 / (1.0 + 0.37 * lam**1.26)


# Peak of g found numerically (independent of the closed form used by the module).
_PEAK = minimize_scalar(
    lambda x: -g_printed(x), bounds=(0.5, 10.0), method="bounded", options={"xatol": 1e-10}
)
LAMBDA_PEAK = float(_PEAK.x)
G_PEAK = g_printed(LAMBDA_PEAK)


def test_peak_of_printed_law() -> None:
    """MODEL_NOTES: g peaks at Lambda = 2.26, with g(L*) = 0.9943 < 1."""
    assert pytest.approx(2.26, abs=0.01) == LAMBDA_PEAK
    assert pytest.approx(0.9943, abs=1e-4) == G_PEAK


def test_load_share_end_points() -> None:
    assert float(traction.load_share_asperities(0.0)) == 1.0
    for lam in (LAMBDA_PEAK + 1e-6, 2.27, 3.0, 8.0, 10.0, 1e3):
        assert float(traction.load_share_asperities(lam)) == pytest.approx(0.0, abs=1e-9)


@pytest.mark.parametrize("lam", [0.01, 0.1, 0.5, 1.0, 1.5, 2.0, 2.2])
def test_load_share_normalised_printed_law(lam: float) -> None:
    """Below the peak f = 1 - g(L)/g(L*) (documented normalisation, D7)."""
    assert float(traction.load_share_asperities(lam)) == pytest.approx(
        1.0 - g_printed(lam) / G_PEAK, rel=1e-6, abs=1e-9
    )


def test_load_share_ratio_to_printed_law() -> None:
    """For small L, (1 - f) / g_printed(L) = 1 / g(L*) (a constant ~ 1.0057)."""
    for lam in (0.05, 0.3, 1.2):
        ratio = (1.0 - float(traction.load_share_asperities(lam))) / g_printed(lam)
        assert ratio == pytest.approx(1.0 / G_PEAK, rel=1e-6)


@settings(max_examples=100, deadline=None)
@given(a=st.floats(0.0, 20.0), b=st.floats(0.0, 20.0))
def test_load_share_monotone_and_bounded(a: float, b: float) -> None:
    lo, hi = min(a, b), max(a, b)
    f_lo = float(traction.load_share_asperities(lo))
    f_hi = float(traction.load_share_asperities(hi))
    assert 0.0 <= f_hi <= f_lo <= 1.0


@settings(max_examples=100, deadline=None)
@given(lam=st.floats(0.0, 10.0))
def test_load_share_continuous(lam: float) -> None:
    """No jumps: |f(L + d) - f(L)| small for small d (the steepest slope is near L = 0, L^0.64)."""
    d = 1e-7
    jump = abs(
        float(traction.load_share_asperities(lam + d)) - float(traction.load_share_asperities(lam))
    )
    assert jump <= 1.3 * d**0.64 + 1e-12


def test_eyring_linear_limit() -> None:
    """eta gamma << tau_e: Newtonian, tau = eta gamma."""
    eta, rate, tau_e = 0.1, 100.0, 5e6
    tau = float(traction.eyring_shear_stress(eta, rate, tau_e, 1e12))
    assert tau == pytest.approx(eta * rate, rel=1e-9)


def test_eyring_logarithmic_limit() -> None:
    """eta gamma >> tau_e: tau = tau_e ln(2 eta gamma / tau_e)."""
    eta, rate, tau_e = 1e6, 1e4, 5e6
    x = eta * rate / tau_e
    tau = float(traction.eyring_shear_stress(eta, rate, tau_e, 1e12))
    # asinh(x) = ln(2x) + 1/(4x^2) + ...: relative remainder ~1e-8 here.
    assert tau == pytest.approx(tau_e * math.log(2.0 * x), rel=1e-6)


def test_eyring_capped_by_limiting_stress() -> None:
    tau_lim = float(traction.limiting_shear_stress(2.5e6, 0.06, 1e9))
    assert tau_lim == pytest.approx(2.5e6 + 0.06e9)
    tau = float(traction.eyring_shear_stress(1e12, 1e6, 5e6, tau_lim))
    assert tau == tau_lim
    # Negative pressure does not lower the limit below tau_L.
    assert float(traction.limiting_shear_stress(2.5e6, 0.06, -1e9)) == 2.5e6


def test_eyring_huge_viscosity_does_not_overflow() -> None:
    """Docstring: astronomically large piezoviscous viscosity must not overflow."""
    with np.errstate(all="raise"):
        tau = float(traction.eyring_shear_stress(1e300, 1e10, 5e6, 1e8))
        uncapped = float(traction.eyring_shear_stress(1e300, 1e10, 5e6, np.inf))
        still = float(traction.eyring_shear_stress(np.inf, 0.0, 5e6, 1e8))
    assert tau == 1e8
    # Far beyond the switch asinh(x) = ln(2x): x = 1e310 / 5e6.
    assert uncapped == pytest.approx(5e6 * (310 * np.log(10) + np.log(2.0) - np.log(5e6)))
    assert still == 0.0


@settings(max_examples=60, deadline=None)
@given(eta=st.floats(1e-3, 1e10), r1=st.floats(0.0, 1e6), r2=st.floats(0.0, 1e6))
def test_eyring_monotone_in_rate(eta: float, r1: float, r2: float) -> None:
    lo, hi = min(r1, r2), max(r1, r2)
    t_lo = float(traction.eyring_shear_stress(eta, lo, 5e6, 6e7))
    t_hi = float(traction.eyring_shear_stress(eta, hi, 5e6, 6e7))
    assert 0.0 <= t_lo <= t_hi <= 6e7


def test_shear_rate_couette() -> None:
    assert float(traction.shear_rate(-0.02, 100e-9)) == pytest.approx(2e5)


def test_dry_friction_factor() -> None:
    assert float(traction.dry_friction_factor(0.0, 1e-4)) == 0.0
    assert float(traction.dry_friction_factor(-1.0, 1e-4)) == pytest.approx(1.0)
    # slope 1/v_r at zero slip
    assert float(traction.dry_friction_factor(1e-9, 1e-4)) == pytest.approx(1e-5, rel=1e-6)


def test_friction_force_split() -> None:
    """Eq. 36: lubricant tau A (1 - f) and dry f mu tanh F; full film and dry limits."""
    tau, area, mu, fn = 3e6, 1e-7, 0.1, 170.0
    lub, dry = traction.friction_force(tau, area, 0.25, mu, 0.5, fn)
    assert float(lub) == pytest.approx(tau * area * 0.75)
    assert float(dry) == pytest.approx(0.25 * mu * 0.5 * fn)
    lub, dry = traction.friction_force(tau, area, 0.0, mu, 1.0, fn)
    assert float(dry) == 0.0 and float(lub) == pytest.approx(tau * area)
    lub, dry = traction.friction_force(tau, area, 1.0, mu, 1.0, fn)
    assert float(lub) == 0.0 and float(dry) == pytest.approx(mu * fn)
