"""Tests of :mod:`ballscrew_twin.physics.hertz` against exact Hertz theory and the paper's screw."""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from numpy.typing import ArrayLike
from scipy.special import ellipe, ellipk

from ballscrew_twin.physics import hertz

from .hertz_oracle import exact_hertz, exact_semi_axis_ratio

STEEL_E = 210e9  # Pa, paper Table A.1
STEEL_NU = 0.29  # -, paper Table A.1
E_STAR = float(hertz.effective_modulus(STEEL_E, STEEL_NU, STEEL_E, STEEL_NU))

# Required agreement of the explicit (Antoine) formulas with exact Hertz theory, relative.
ANTOINE_TOLERANCE = 1e-4
CONTACT_FIELDS = hertz.HertzContact._fields

# Bounded hypothesis floats exclude NaN and infinities by default.
ratios = st.floats(1.0, 1e4)
forces = st.floats(1e-2, 1e4)
radii = st.floats(1e-4, 0.1)
moduli = st.floats(1e9, 1e12)


def max_relative_errors(
    curvature_ratios: ArrayLike, *, major_along_x: bool, force: float = 170.0, radius: float = 2e-3
) -> dict[str, float]:
    """Largest relative error of the explicit module against the exact oracle, per quantity.

    One vectorised module call over all curvature ratios R_max / R_min, the larger radius along x
    if ``major_along_x`` else along y; "semi_axis_ratio" is :func:`hertz.ellipticity_antoine`.
    """
    ratio = np.asarray(curvature_ratios, dtype=np.float64)
    small = np.full_like(ratio, radius)
    r_x, r_y = (radius * ratio, small) if major_along_x else (small, radius * ratio)
    approx = hertz.hertz_contact(force, r_x, r_y, E_STAR)
    approx_k = hertz.ellipticity_antoine(r_x, r_y)
    errors = dict.fromkeys((*CONTACT_FIELDS, "semi_axis_ratio"), 0.0)
    for i, r in enumerate(ratio):
        exact = exact_hertz(force, float(r_x[i]), float(r_y[i]), E_STAR)
        for name in CONTACT_FIELDS:
            error = abs(getattr(approx, name)[i] / getattr(exact, name) - 1.0)
            errors[name] = max(errors[name], error)
        k_error = abs(approx_k[i] / exact_semi_axis_ratio(float(r)) - 1.0)
        errors["semi_axis_ratio"] = max(errors["semi_axis_ratio"], k_error)
    return errors


# ---------------------------------------------------------------------------------------------
# Moduli and elliptic integrals
# ---------------------------------------------------------------------------------------------


def test_moduli_of_paper_steel() -> None:
    """E* = 114.64 GPa and E' = 2 E* = 229.28 GPa (MODEL_NOTES section 1), to printed digits."""
    assert round(E_STAR / 1e9, 2) == 114.64
    e_prime = float(hertz.reduced_modulus_ehl(STEEL_E, STEEL_NU, STEEL_E, STEEL_NU))
    assert round(e_prime / 1e9, 2) == 229.28
    assert e_prime == pytest.approx(2.0 * E_STAR, rel=1e-15)


def test_effective_modulus_of_dissimilar_bodies() -> None:
    """1/E* is the sum of the two compliances (1 - nu^2)/E."""
    e_star = hertz.effective_modulus(310e9, 0.26, 210e9, 0.29)
    expected = 1.0 / ((1.0 - 0.26**2) / 310e9 + (1.0 - 0.29**2) / 210e9)
    assert float(e_star) == pytest.approx(expected, rel=1e-15)


def test_elliptic_integrals_match_scipy() -> None:
    """Abramowitz-Stegun 17.3.34/36 stay within their stated 2e-8 of scipy's exact values."""
    m = np.concatenate([np.linspace(0.0, 0.99, 100), 1.0 - np.logspace(-2, -12, 50)])
    ell_k, ell_e = hertz.complete_elliptic_integrals(m)
    np.testing.assert_allclose(ell_k, ellipk(m), rtol=0.0, atol=2e-8)
    np.testing.assert_allclose(ell_e, ellipe(m), rtol=0.0, atol=2e-8)


# ---------------------------------------------------------------------------------------------
# Antoine's explicit formulas against exact Hertz theory
# ---------------------------------------------------------------------------------------------


def test_ellipticity_is_one_for_equal_radii_and_symmetric() -> None:
    """k = 1 for a circle; swapping R_x and R_y leaves the semi-axis ratio unchanged."""
    assert float(hertz.ellipticity_antoine(3e-3, 3e-3)) == 1.0
    r_x = np.array([1e-3, 2e-3, 5e-2])
    r_y = np.array([4e-3, 2e-3, 1e-3])
    np.testing.assert_array_equal(
        hertz.ellipticity_antoine(r_x, r_y), hertz.ellipticity_antoine(r_y, r_x)
    )


@pytest.mark.parametrize("major_along_x", [False, True], ids=["R_y>R_x", "R_x>R_y"])
def test_antoine_matches_exact_over_ratio_range(major_along_x: bool) -> None:
    """Every quantity within 1e-4 of exact Hertz for curvature ratios 1 to 1e4."""
    errors = max_relative_errors(np.logspace(0.0, 4.0, 801), major_along_x=major_along_x)
    assert errors == pytest.approx(dict.fromkeys(errors, 0.0), abs=ANTOINE_TOLERANCE)


@given(ratio=ratios, force=forces, radius=radii, e_star=moduli, major_along_x=st.booleans())
def test_antoine_matches_exact_random(
    ratio: float, force: float, radius: float, e_star: float, major_along_x: bool
) -> None:
    """Random loads, sizes, moduli and orientations: within 1e-4 of exact Hertz."""
    r_x, r_y = (radius * ratio, radius) if major_along_x else (radius, radius * ratio)
    approx = hertz.hertz_contact(force, r_x, r_y, e_star)
    exact = exact_hertz(force, r_x, r_y, e_star)
    for name in CONTACT_FIELDS:
        assert float(getattr(approx, name)) == pytest.approx(
            getattr(exact, name), rel=ANTOINE_TOLERANCE
        ), name


def test_major_axis_lies_along_larger_radius() -> None:
    """The contact ellipse is elongated along the direction of smaller curvature."""
    along_y = hertz.hertz_contact(100.0, 1e-3, 3e-2, E_STAR)
    along_x = hertz.hertz_contact(100.0, 3e-2, 1e-3, E_STAR)
    assert along_y.semi_axis_y > along_y.semi_axis_x
    assert float(along_x.semi_axis_x) == float(along_y.semi_axis_y)
    assert float(along_x.semi_axis_y) == float(along_y.semi_axis_x)


@pytest.mark.parametrize("solver", [hertz.hertz_contact, exact_hertz], ids=["module", "oracle"])
@pytest.mark.parametrize("force", [1e-3, 1.0, 170.2, 5e4])
@pytest.mark.parametrize("radius", [1e-4, 1.5875e-3, 0.1])
def test_circular_limit_is_the_sphere_solution(
    solver: Callable[[float, float, float, float], tuple[ArrayLike, ...]],
    force: float,
    radius: float,
) -> None:
    """R_x = R_y = R: a = (3FR/4E*)^(1/3), delta = a^2/R, p0 = 3F/(2 pi a^2) (Johnson 4.2)."""
    contact = solver(force, radius, radius, E_STAR)
    a = (3.0 * force * radius / (4.0 * E_STAR)) ** (1.0 / 3.0)
    expected = {
        "semi_axis_x": a,
        "semi_axis_y": a,
        "approach": a**2 / radius,
        "max_pressure": 3.0 * force / (2.0 * math.pi * a**2),
        "mean_pressure": force / (math.pi * a**2),
        "area": math.pi * a**2,
        "stiffness": 4.0 / 3.0 * E_STAR * math.sqrt(radius),
    }
    for name, value in expected.items():
        assert float(getattr(contact, name)) == pytest.approx(value, rel=1e-9), name


# ---------------------------------------------------------------------------------------------
# The paper's screw (MODEL_NOTES section 3)
# ---------------------------------------------------------------------------------------------

BALL_RADIUS = 1.5875e-3  # m, r_b
GROOVE_RADIUS = 0.528 * 2.0 * BALL_RADIUS  # m, r_s = 2 f r_b
PITCH_RADIUS = 8e-3  # m, r_m
HELIX_ANGLE = math.radians(5.6806)
CONTACT_ANGLE = math.radians(45.13)
BALL_LOAD = 170.2  # N, Q at 3000 N preload


def _paper_radii(side: str) -> tuple[float, float]:
    """(R_x, R_y) [m] of the sphere on the screw or nut groove (Meusnier, MODEL_NOTES 3)."""
    convex = 1.0 if side == "screw" else -1.0  # screw groove convex along x, nut groove concave
    cos_a = math.cos(CONTACT_ANGLE)
    groove_x = (
        convex * cos_a * math.cos(HELIX_ANGLE) ** 2 / (PITCH_RADIUS - convex * BALL_RADIUS * cos_a)
    )
    curvature_x = 1.0 / BALL_RADIUS + groove_x
    curvature_y = 1.0 / BALL_RADIUS - 1.0 / GROOVE_RADIUS
    return 1.0 / curvature_x, 1.0 / curvature_y


# Printed values and the unit of their last printed digit (MODEL_NOTES section 3 table).
PAPER_TABLE = {
    "screw": {
        "max_pressure": (2.72e9, 0.01e9),
        "semi_axis_x": (63.8e-6, 0.1e-6),
        "semi_axis_y": (467e-6, 1e-6),
        "approach": (5.14e-6, 0.01e-6),
        "stiffness": (1.461e10, 0.001e10),
    },
    "nut": {
        "max_pressure": (2.40e9, 0.01e9),
        "semi_axis_x": (74.0e-6, 0.1e-6),
        "semi_axis_y": (457e-6, 1e-6),
        "approach": (5.00e-6, 0.01e-6),
        "stiffness": (1.523e10, 0.001e10),
    },
}


@pytest.mark.parametrize("side", ["screw", "nut"])
def test_paper_screw_sanity_numbers(side: str) -> None:
    """Q = 170.2 N on the paper's screw reproduces the MODEL_NOTES table to its printed digits."""
    r_x, r_y = _paper_radii(side)
    contact = hertz.hertz_contact(BALL_LOAD, r_x, r_y, E_STAR)
    for name, (printed, last_digit) in PAPER_TABLE[side].items():
        assert abs(float(getattr(contact, name)) - printed) <= 0.5 * last_digit, name
    assert float(hertz.hertz_stiffness(r_x, r_y, E_STAR)) == float(contact.stiffness)


# ---------------------------------------------------------------------------------------------
# Consistency between the force and approach forms; zero load; shapes
# ---------------------------------------------------------------------------------------------


@given(ratio=ratios, force=forces, radius=radii, e_star=moduli)
def test_contact_from_approach_inverts_hertz_contact(
    ratio: float, force: float, radius: float, e_star: float
) -> None:
    """F -> delta -> contact_from_approach gives the same contact, and F = K_H delta^1.5."""
    by_force = hertz.hertz_contact(force, radius, radius * ratio, e_star)
    by_approach = hertz.contact_from_approach(by_force.approach, radius, radius * ratio, e_star)
    for name in CONTACT_FIELDS:
        assert float(getattr(by_approach, name)) == pytest.approx(
            float(getattr(by_force, name)), rel=1e-12
        ), name
    stiffness = hertz.hertz_stiffness(radius, radius * ratio, e_star)
    assert float(stiffness * by_force.approach**1.5) == pytest.approx(force, rel=1e-12)


@pytest.mark.parametrize("load", [0.0, -5.0])
def test_zero_or_negative_load_and_approach_give_empty_contact(load: float) -> None:
    """F <= 0 or delta <= 0: zero dimensions and pressures, finite stiffness, no warnings."""
    with np.errstate(all="raise"):
        contacts = [
            hertz.hertz_contact(load, 1e-3, 3e-2, E_STAR),
            hertz.contact_from_approach(load * 1e-6, 1e-3, 3e-2, E_STAR),
        ]
    expected_stiffness = float(hertz.hertz_stiffness(1e-3, 3e-2, E_STAR))
    for contact in contacts:
        for name in CONTACT_FIELDS[:-1]:
            assert float(getattr(contact, name)) == 0.0, name
        assert float(contact.stiffness) == expected_stiffness


def test_vectorised_calls_broadcast_inputs() -> None:
    """Outputs are float64 ndarrays of the broadcast input shape; zero loads give no NaN."""
    force = np.array([[0.0], [10.0], [170.0]])  # (3, 1)
    r_x = np.array([1e-3, 2e-3, 4e-3, 8e-3])  # (4,)
    contact = hertz.hertz_contact(force, r_x, 3e-2, E_STAR)
    by_approach = hertz.contact_from_approach(force * 1e-8, r_x, 3e-2, E_STAR)
    for name in CONTACT_FIELDS:
        for value in (getattr(contact, name), getattr(by_approach, name)):
            assert isinstance(value, np.ndarray)
            assert value.shape == (3, 4), name
            assert value.dtype == np.float64
            assert np.all(np.isfinite(value)), name
    assert hertz.hertz_stiffness(r_x, 3e-2, E_STAR).shape == (4,)
    assert hertz.ellipticity_antoine(r_x[:, None], r_x).shape == (4, 4)
    delta = np.array([[-1e-6], [0.0], [5e-6]])  # (3, 1) m
    rate = np.array([-1.0, 0.0, 0.01, 1.0])  # (4,) m/s
    assert hertz.normal_force(delta, rate, 1.461e10, 1e-3).shape == (3, 4)
    ball_moduli = np.array([200e9, 210e9, 310e9, 400e9])  # (4,) Pa
    ball, groove = hertz.deformation_split(delta, ball_moduli, 0.3, STEEL_E, STEEL_NU)
    assert ball.shape == groove.shape == (3, 4)


def test_scalar_inputs_give_zero_dimensional_arrays() -> None:
    """Scalars in, 0-d float64 ndarrays out."""
    outputs = [
        *hertz.hertz_contact(170.0, 1e-3, 3e-2, E_STAR),
        hertz.hertz_stiffness(1e-3, 3e-2, E_STAR),
        hertz.ellipticity_antoine(1e-3, 3e-2),
        hertz.effective_modulus(STEEL_E, STEEL_NU, STEEL_E, STEEL_NU),
        hertz.normal_force(1e-6, 0.0, 1e10, 1e-3),
        *hertz.deformation_split(1e-6, STEEL_E, STEEL_NU, STEEL_E, STEEL_NU),
        *hertz.complete_elliptic_integrals(0.5),
    ]
    for value in outputs:
        assert isinstance(value, np.ndarray)
        assert value.shape == ()
        assert value.dtype == np.float64


# ---------------------------------------------------------------------------------------------
# Normal contact law (Eqs. 18-19) and deformation split (Eqs. 20-21)
# ---------------------------------------------------------------------------------------------

K_H = 1.461e10  # N m^-1.5, screw side of the paper's screw
B_H = 1e-3  # kg^0.5 m^0.25


@pytest.mark.parametrize("delta", [0.0, -1e-9, -1e-3])
@pytest.mark.parametrize("rate", [-10.0, 0.0, 10.0])
def test_normal_force_is_zero_without_interpenetration(delta: float, rate: float) -> None:
    """delta <= 0: no contact, no force whatever the rate."""
    assert float(hertz.normal_force(delta, rate, K_H, B_H)) == 0.0


def test_normal_force_elastic_and_damped() -> None:
    """F = K delta^1.5 (1 + tanh(C_H rate / (K delta^1.5))) (D14): the pure Hertz force at rest,
    K delta^1.5 + C_H rate to second order while C_H rate << K delta^1.5 (Eq. 18)."""
    delta = 5e-6
    elastic = K_H * delta**1.5
    assert float(hertz.normal_force(delta, 0.0, K_H, B_H)) == pytest.approx(elastic, rel=1e-15)
    rate = 0.01  # m/s: C_H rate = 1.2 N, well below the 162 N elastic force
    damping = B_H * math.sqrt(K_H) * rate
    x = damping / elastic
    assert x < 0.01
    for sign in (1.0, -1.0):
        force = float(hertz.normal_force(delta, sign * rate, K_H, B_H))
        assert force == pytest.approx(elastic * (1.0 + math.tanh(sign * x)), rel=1e-14)
        # tanh(x) = x - x^3/3 + ...: the linear law of Eq. 18 to relative order x^2 / 3.
        assert force == pytest.approx(elastic + sign * damping, rel=x**2)


def test_normal_force_damping_saturates_at_elastic_force() -> None:
    """A fast approach at most doubles the force; a fast release drives it to zero, not below."""
    delta = 1e-7
    elastic = K_H * delta**1.5
    assert float(hertz.normal_force(delta, 1e3, K_H, B_H)) == pytest.approx(2.0 * elastic)
    assert float(hertz.normal_force(delta, -1e3, K_H, B_H)) == 0.0


def test_damping_of_a_vanishing_approach_saturates_without_overflow() -> None:
    """An approach so small that K_H delta^1.5 is near the underflow limit: C_H rate over it
    overflows, and the force is still the saturated one, with no floating-point warning (a
    hypothesis example found the warning)."""
    delta = np.array([1e-212, 1e-212, 1e-215])
    rate = np.array([1.0, -1.0, 0.5])
    elastic = K_H * delta**1.5
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        force = hertz.normal_force(delta, rate, K_H, B_H)
    np.testing.assert_array_equal(force, [2.0 * elastic[0], 0.0, 2.0 * elastic[2]])


@given(
    delta=st.floats(-1e-4, 1e-4),
    rate=st.floats(-100.0, 100.0),
    stiffness=st.floats(1e6, 1e12),
    b_h=st.floats(0.0, 10.0),
)
def test_normal_force_is_never_negative(
    delta: float, rate: float, stiffness: float, b_h: float
) -> None:
    """No attractive force for any approach, rate, stiffness and damping coefficient."""
    assert float(hertz.normal_force(delta, rate, stiffness, b_h)) >= 0.0


def test_deformation_split_of_equal_materials_is_half_each() -> None:
    """Same material for sphere and groove: each takes delta / 2."""
    ball, groove = hertz.deformation_split(5e-6, STEEL_E, STEEL_NU, STEEL_E, STEEL_NU)
    assert float(ball) == float(groove) == pytest.approx(2.5e-6, rel=1e-15)


@given(
    # 0, or |delta| in [1e-30, 1e-4] m: below, the split's products underflow into subnormal
    # numbers with no relative precision left (no physical approach is that small).
    delta=st.one_of(st.just(0.0), st.floats(1e-30, 1e-4), st.floats(-1e-4, -1e-30)),
    e_ball=moduli,
    nu_ball=st.floats(0.0, 0.5),
    e_groove=moduli,
    nu_groove=st.floats(0.0, 0.5),
)
def test_deformation_split_sums_and_follows_eq21(
    delta: float, e_ball: float, nu_ball: float, e_groove: float, nu_groove: float
) -> None:
    """Eq. 20: the parts sum to delta; Eq. 21: their ratio is (1-nu_g^2) E_b / ((1-nu_b^2) E_g)."""
    ball, groove = hertz.deformation_split(delta, e_ball, nu_ball, e_groove, nu_groove)
    assert float(ball + groove) == pytest.approx(delta, rel=1e-14, abs=1e-30)
    if delta != 0.0:
        expected_ratio = (1.0 - nu_groove**2) * e_ball / ((1.0 - nu_ball**2) * e_groove)
        assert float(groove / ball) == pytest.approx(expected_ratio, rel=1e-13)
