"""Tests of :mod:`ballscrew_twin.physics.rolling` (Eqs. 39-45) against independent oracles."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ballscrew_twin.physics import rolling

R_B = 1.5875e-3
R_S = 2.0 * 0.528 * R_B
E_PRIME = 210e9 / (1.0 - 0.29**2)
RX = 1.3e-3  # m, screw-side order of magnitude
RY = 1.0 / (1.0 / R_B - 1.0 / R_S)
ETA = 0.09


def fr(f: float, u: float, eta: float = ETA) -> float:
    return float(rolling.rolling_resistance_force(f, u, eta, RX, RY, E_PRIME))


def test_spin_factor_limits() -> None:
    """Eq. 45 bracket: circle 3 pi / 16, thin ellipse -> 3/8 (MODEL_NOTES: limits hold)."""
    assert float(rolling.spin_moment_factor(1.0)) == pytest.approx(3.0 * math.pi / 16.0, rel=1e-12)
    assert float(rolling.spin_moment_factor(1e8)) == pytest.approx(0.375, rel=1e-3)
    ks = np.geomspace(1.0, 1e6, 200)
    vals = rolling.spin_moment_factor(ks)
    assert np.all(np.diff(vals) <= 0.0)
    assert np.all((vals >= 0.375) & (vals <= 3.0 * math.pi / 16.0 + 1e-15))


def test_spin_moment_product() -> None:
    assert float(rolling.spin_moment(0.5, 4e-4, 2.0)) == pytest.approx(4e-4)


def test_hysteresis_moment_scaling() -> None:
    """MER ~ r_b^0.33 F^1.33 (Eq. 43) and proportional to mu_s / mu_dry."""
    base = float(rolling.hysteresis_moment(100.0, R_B, 10.0, 0.01, 0.1))
    assert float(rolling.hysteresis_moment(200.0, R_B, 10.0, 0.01, 0.1)) == pytest.approx(
        base * 2.0**1.33, rel=1e-12
    )
    assert float(rolling.hysteresis_moment(100.0, 2.0 * R_B, 10.0, 0.01, 0.1)) == pytest.approx(
        base * 2.0**0.33, rel=1e-12
    )
    assert float(rolling.hysteresis_moment(100.0, R_B, 10.0, 0.02, 0.1)) == pytest.approx(
        2.0 * base, rel=1e-12
    )


def test_hysteresis_moment_hand_written() -> None:
    """Eq. 43 written out with r_b in m (D9)."""
    f, ratio, mu_s, mu = 170.0, 23.0, 0.005, 0.1
    expected = (
        7.48e-7 * R_B**0.33 * f**1.33 * (1.0 - 3.519e-3 * (ratio - 1.0) ** 0.8063) * mu_s / mu
    )
    got = float(rolling.hysteresis_moment(f, R_B, ratio, mu_s, mu))
    assert got == pytest.approx(expected, rel=1e-12)
    assert float(rolling.hysteresis_moment(0.0, R_B, ratio, mu_s, mu)) == 0.0


def test_pressure_force_ratio() -> None:
    """FP / FR = 2 R_x / (R_x + r_b) (Eq. 42); equals 1 when R_x = r_b."""
    assert float(rolling.pressure_rolling_force(3.0, RX, R_B)) / 3.0 == pytest.approx(
        2.0 * RX / (RX + R_B), rel=1e-12
    )
    assert float(rolling.pressure_rolling_force(3.0, R_B, R_B)) == pytest.approx(3.0)


# D16 as documented: the speed |u|_e = sqrt(u^2 + u_e^2), u_e = 0.1 mm/s, written out here.
U_SMOOTH = 1e-4


def fr_paper(f: float, u: float) -> float:
    """Eqs. 39-41 with W, U on the mean speed |u| (unsmoothed), written out here."""
    w = f / (E_PRIME * RX**2)
    uu = ETA * abs(u) / (E_PRIME * RX)
    lam = RX / RY
    ivr = 2.9766 * E_PRIME * RX**2 * lam**-0.3316 * w ** (1 / 3) * uu ** (2 / 3)
    ehl = 7.5826 * E_PRIME * RX**2 * lam**-0.4055 * w ** (1 / 3) * uu**0.75
    return float((ivr - ehl) / (1.0 + 0.0841 * lam**0.6029 * w * uu**-0.75) + ehl)


def test_rolling_resistance_hand_written() -> None:
    """Eqs. 39-41 on the smoothed speed (D16): FR(u) is the paper's FR at |u|_e."""
    for u in (0.04, -0.003, 0.0):
        assert fr(170.0, u) == pytest.approx(fr_paper(170.0, math.hypot(u, U_SMOOTH)), rel=1e-12)


def test_rolling_resistance_is_the_papers_away_from_zero_speed() -> None:
    """D16: for |u| >= 100 u_e, FR equals the unsmoothed law to (u_e/u)^2 relative."""
    for u in np.geomspace(100.0 * U_SMOOTH, 2.0, 30).tolist():
        assert abs(fr(170.0, u) / fr_paper(170.0, u) - 1.0) <= (U_SMOOTH / u) ** 2


def test_rolling_resistance_force_through_zero_speed() -> None:
    """FR along the entrainment, FR(u) u/|u|_e (D16), is odd, continuous through u = 0 and
    has a finite slope there, FR(0)/u_e; the paper's FR sign(u) ~ |u|^(2/3) does not."""
    assert float(rolling.smoothed_sign(0.0)) == 0.0
    assert float(rolling.smoothed_sign(3.0)) == pytest.approx(1.0, abs=1e-8)
    assert float(rolling.smoothed_sign(-3.0)) == pytest.approx(-1.0, abs=1e-8)

    def along(u: float) -> float:
        return fr(170.0, u) * float(rolling.smoothed_sign(u))

    slope_at_zero = fr(170.0, 0.0) / U_SMOOTH
    for du in (1e-7, 1e-8, 1e-9):
        assert along(-du) == pytest.approx(-along(du), rel=1e-12)
        assert along(du) / du == pytest.approx(slope_at_zero, rel=1e-6)
    # The paper's slope grows as u^(-1/3) down there: 4.6 times per factor 100.
    assert fr_paper(170.0, 1e-9) / 1e-9 > 3.0 * fr_paper(170.0, 1e-7) / 1e-7


def test_rolling_resistance_zero_cases() -> None:
    assert fr(0.0, 0.1) == 0.0
    assert fr(170.0, 0.1) > 0.0
    assert fr(170.0, -0.1) == fr(170.0, 0.1)


@settings(max_examples=60, deadline=None)
@given(
    f=st.floats(1.0, 2000.0),
    u=st.floats(1e-4, 5.0),
    k=st.floats(1.01, 10.0),
    eta=st.floats(1e-3, 10.0),
)
def test_rolling_resistance_increases_with_speed_and_viscosity(
    f: float, u: float, k: float, eta: float
) -> None:
    base = fr(f, u, eta)
    assert base > 0.0
    assert fr(f, k * u, eta) > base
    assert fr(f, u, k * eta) > base


def test_rolling_resistance_ehl_limit_exponent() -> None:
    """Heavily loaded (EHL) limit: FR -> FR_EHL ~ u^0.75 (blend term dominates), at speeds
    20-200 u_e where the smoothing of D16 moves FR by under 0.1 %."""
    speeds = np.geomspace(2e-3, 2e-2, 5)
    vals = np.array([fr(1000.0, u) for u in speeds])
    slope = np.polyfit(np.log(speeds), np.log(vals), 1)[0]
    assert 0.7 <= slope <= 0.76


def test_curvature_moment() -> None:
    """MC = 0.0806 mu_s F a_y^2 / R_c with R_c = 2 r_b r_s / (r_b + r_s) (~1.63 mm, notes)."""
    rc = rolling.deformed_surface_radius(R_B, R_S)
    assert rc == pytest.approx(1.63e-3, abs=0.01e-3)
    assert rc == pytest.approx(1.0 / (0.5 / R_B + 0.5 / R_S), rel=1e-12)
    m1 = float(rolling.curvature_moment(170.0, 4.6e-4, rc, 0.01))
    assert m1 == pytest.approx(0.0806 * 0.01 * 170.0 * 4.6e-4**2 / rc, rel=1e-12)
    m2 = float(rolling.curvature_moment(170.0, 2.0 * 4.6e-4, rc, 0.01))
    assert m2 == pytest.approx(4.0 * m1, rel=1e-12)
    assert float(rolling.curvature_moment(-5.0, 4.6e-4, rc, 0.01)) == 0.0
