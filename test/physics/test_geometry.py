"""Tests of :mod:`ballscrew_twin.physics.geometry` (paper section 2.1) with independent oracles."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ballscrew_twin.params import load_config
from ballscrew_twin.physics import geometry as geo

CFG = load_config()
GEOM = CFG.screw
# Table A.1 values written out by hand.
R_M, LEAD, R_B, F_CONF, H, L = 8.0e-3, 5.0e-3, 1.5875e-3, 0.528, 0.0629e-3, 0.0505e-3
R_S = 2.0 * F_CONF * R_B


def test_free_contact_angle_paper_screw() -> None:
    """acos(H / (r_s - r_b)) = 44.97 deg (MODEL_NOTES, Table A.1 prints 45.13)."""
    expected = math.degrees(math.acos(H / (R_S - R_B)))
    assert expected == pytest.approx(44.97, abs=0.005)
    assert math.degrees(GEOM.free_contact_angle) == pytest.approx(expected, rel=1e-12)
    assert GEOM.groove_radius == pytest.approx(1.6764e-3, rel=1e-4)
    assert math.degrees(GEOM.helix_angle) == pytest.approx(5.6806, abs=1e-4)


def test_first_touch_offset_with_s2() -> None:
    """Ball moved along +b until it first touches S2: zero approach, angle 44.97 deg."""
    b0 = math.sqrt((R_S - R_B) ** 2 - H**2) - L
    centres = geo.half_groove_centres(GEOM, 0.0)
    approach, normal, angle = geo.contact_geometry(np.array([0.0, b0]), centres, R_B, R_S)
    assert approach[geo.S2] == pytest.approx(0.0, abs=1e-15)
    assert math.degrees(angle[geo.S2]) == pytest.approx(44.97, abs=0.005)
    assert np.linalg.norm(normal[geo.S2]) == pytest.approx(1.0)
    # Moving away from S2 it must lose contact with S1 (other side, separated).
    assert approach[geo.S1] < 0.0


def test_centred_ball_clearance() -> None:
    """MODEL_NOTES: a centred ball has 8.24 um clearance to each half groove."""
    centres = geo.half_groove_centres(GEOM, 0.0)
    approach, _, _ = geo.contact_geometry(np.zeros(2), centres, R_B, R_S)
    clearance = R_S - R_B - math.hypot(H, L)
    assert clearance == pytest.approx(8.24e-6, abs=0.01e-6)
    np.testing.assert_allclose(approach, -clearance, rtol=1e-9)


def test_half_groove_centres_layout() -> None:
    c = geo.half_groove_centres(GEOM, 1e-5)
    np.testing.assert_allclose(
        c, [[-H, L], [-H, -L], [H, L + 1e-5], [H, -L + 1e-5]], rtol=1e-12, atol=1e-18
    )


def test_contact_exists_window() -> None:
    lo, hi = 0.2, 1.3
    approach = np.array([1e-6, 1e-6, 1e-6, -1e-6, 0.0, 1e-6, 1e-6])
    angle = np.array([0.7, lo, hi, 0.7, 0.7, lo - 1e-3, hi + 1e-3])
    got = geo.contact_exists(approach, angle, lo, hi)
    np.testing.assert_array_equal(got, [True, True, True, False, False, False, False])


def helix(theta: float, lam: float) -> np.ndarray:
    """Eq. 2: R_B/O = r_m (cos th, sin th, th tan l)."""
    return R_M * np.array([math.cos(theta), math.sin(theta), theta * math.tan(lam)])


@settings(max_examples=50, deadline=None)
@given(theta=st.floats(-20.0, 20.0), lam=st.floats(0.01, 0.6))
def test_frenet_frame(theta: float, lam: float) -> None:
    frame = geo.frenet_frame(theta, lam)
    t, n, b = frame
    np.testing.assert_allclose(frame @ frame.T, np.eye(3), atol=1e-12)
    np.testing.assert_allclose(np.cross(t, n), b, atol=1e-12)
    # t along the derivative of Eq. 2 (central difference).
    d = 1e-6
    deriv = (helix(theta + d, lam) - helix(theta - d, lam)) / (2.0 * d)
    np.testing.assert_allclose(t, deriv / np.linalg.norm(deriv), atol=1e-8)
    # n points from the helix point towards the axis, perpendicular to it.
    radial = -helix(theta, lam)
    radial[2] = 0.0
    np.testing.assert_allclose(n, radial / np.linalg.norm(radial), atol=1e-12)
    # Axis direction components (t, n, b) = frame @ z.
    np.testing.assert_allclose(
        frame @ np.array([0.0, 0.0, 1.0]), geo.axis_direction(lam), atol=1e-12
    )


def helix_normal_curvature(alpha: float, nut: bool) -> float:
    """Curvature of the helix (same lead) through the contact point, projected on the normal.

    A helix of radius rho and lead p has curvature rho / (rho^2 + (p / 2 pi)^2), its principal
    normal pointing at the axis; the surface normal makes angle alpha with it: times cos(alpha).
    """
    rho = R_M + (1.0 if nut else -1.0) * R_B * math.cos(alpha)
    c = LEAD / (2.0 * math.pi)
    return (-1.0 if nut else 1.0) * math.cos(alpha) * rho / (rho**2 + c**2)


@pytest.mark.parametrize("alpha_deg", [35.0, 44.97, 55.0])
@pytest.mark.parametrize("groove", [geo.S1, geo.S2, geo.N1, geo.N2])
def test_principal_curvature_vs_helix(alpha_deg: float, groove: int) -> None:
    alpha = math.radians(alpha_deg)
    nut = groove in (geo.N1, geo.N2)
    rolling, transverse = geo.principal_curvatures(GEOM, alpha, groove)
    assert float(rolling) == pytest.approx(helix_normal_curvature(alpha, nut), rel=5e-3)
    assert float(transverse) == pytest.approx(-1.0 / R_S, rel=1e-12)


def test_reduced_radii() -> None:
    rx, ry = geo.reduced_radii(R_B, 100.0, -1.0 / R_S)
    assert float(rx) == pytest.approx(R_B / (1.0 + 100.0 * R_B))
    assert float(ry) == pytest.approx(R_B * R_S / (R_S - R_B))


def test_thermal_expansion_uniform_scaling() -> None:
    """Equal coefficients: every length scales by 1 + a dT, conformity and angles unchanged."""
    t = 253.15
    new = geo.thermally_expanded(GEOM, CFG.materials, t)
    s = 1.0 + 11.5e-6 * (t - 293.15)
    for name in ("pitch_radius", "lead", "ball_radius", "centre_offset", "ogival_offset"):
        assert getattr(new, name) == pytest.approx(getattr(GEOM, name) * s, rel=1e-12)
    assert new.conformity == pytest.approx(GEOM.conformity, rel=1e-12)
    assert new.helix_angle == pytest.approx(GEOM.helix_angle, rel=1e-12)
    assert new.free_contact_angle == pytest.approx(GEOM.free_contact_angle, rel=1e-12)
    assert geo.nut_expansion_mismatch(CFG.materials, t) == 0.0


def test_thermal_expansion_different_ball() -> None:
    """A ball expanding more than the screw lowers the conformity: f' = f (1+a_s dT)/(1+a_b dT)."""
    mats = replace(CFG.materials, ball=replace(CFG.materials.ball, thermal_expansion=20e-6))
    t = 353.15
    new = geo.thermally_expanded(GEOM, mats, t)
    dt = t - 293.15
    assert new.conformity == pytest.approx(
        F_CONF * (1.0 + 11.5e-6 * dt) / (1.0 + 20e-6 * dt), rel=1e-12
    )
    assert new.groove_radius == pytest.approx(R_S * (1.0 + 11.5e-6 * dt), rel=1e-12)
