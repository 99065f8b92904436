"""Hertz point contact: explicit elliptical-contact formulas and the normal contact law.

Paper section 2.2 (Eqs. 17-21) computes the normal force of each sphere/half-groove contact from
the rigid-body interpenetration (the approach) delta with the Hertz law F = K_H delta^1.5, K_H from
the explicit formulation of Antoine et al. (2006). Everything here is a pure function on numpy
arrays (scalars or arrays, broadcast together), SI units: m, N, Pa.

Geometry and notation (Johnson, "Contact Mechanics", 1985, section 4.2). Near the first contact
point the gap between the undeformed surfaces is h = A x^2 + B y^2 with

    A = 1 / (2 R_x),   B = 1 / (2 R_y),

where R_x (rolling direction x) and R_y (transverse direction y) are the effective radii of
curvature: 1/R_x is the sum of the two bodies' curvatures in x (convex positive), likewise in y.
Both must be positive and finite; either may be the larger. The contact ellipse has its MINOR
semi-axis b along the direction of larger curvature (smaller radius) and its MAJOR semi-axis a
along the direction of larger radius. The ellipse ratio k = a / b >= 1 depends on the curvature
ratio alone, through Johnson's Eq. (4.39)::

    B/A = (k^2 E(m) - K(m)) / (K(m) - E(m)),   m = e^2 = 1 - 1/k^2   (taking B >= A),

with K, E the complete elliptic integrals of the first and second kind of PARAMETER m (the
convention of scipy.special.ellipk; Johnson writes K(e), E(e) with the modulus e = sqrt(m)).
Johnson's Eqs. (4.36)-(4.38) then give, with p0 the maximum pressure and E* the contact modulus,

    A + B = p0 E(m) / (E* b),     delta = p0 b K(m) / E*,     F = (2/3) pi a b p0,

from which every quantity below follows explicitly once k is known:

    b^3 = 3 F E(m) / (2 pi k E* (A + B)),     b^2 = delta E(m) / ((A + B) K(m)),
    F = K_H delta^1.5,   K_H = eps(k) (4/3) E* sqrt(R_e),
    R_e = 1 / (A + B) = 2 / (1/R_x + 1/R_y),   eps(k) = pi k sqrt(E(m)) / (2 K(m)^1.5).

The equivalent radius that makes K_H correct is therefore R_e = 2 / (1/R_x + 1/R_y) (as written
in MODEL_NOTES section 3), with the eccentricity factor eps(k); eps(1) = 1, so in the circular
limit R_x = R_y = R this is the sphere law K_H = (4/3) E* sqrt(R). Johnson's other equivalent
radius sqrt(R_x R_y) belongs to his approximate formulas for sqrt(a b) and is not used here.

k is taken from the explicit fit of Antoine et al. (2006) and K(m), E(m) from the polynomial
approximations of Abramowitz and Stegun (1972) 17.3.34 and 17.3.36, so nothing iterates.

References:
    Antoine J.-F., Visa C., Sauvey C., Abba G., "Approximate analytical model for Hertzian
    elliptical contact problems", ASME J. Tribology 128:660-664, 2006.
    Johnson K. L., "Contact Mechanics", Cambridge University Press, 1985, chapter 4.
    Abramowitz M., Stegun I. A., "Handbook of Mathematical Functions", Dover, 1972, 17.3.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

FloatArray = NDArray[np.float64]

# Antoine et al. (2006): k = (B/A)^p, p = (2/3) N(q) / D(q), q = log10(B/A)^2, with
# N(q) = 1 + sum_i u_i q^(i+1) and D(q) = 1 + sum_i v_i q^(i+1).
_ANTOINE_NUMERATOR = (1.0, 0.40227436, 3.7491752e-2, 7.4855761e-4, 2.1667028e-6)
_ANTOINE_DENOMINATOR = (1.0, 0.42678878, 4.2605401e-2, 9.0786922e-4, 2.7868927e-6)

# Abramowitz & Stegun 17.3.34 (K) and 17.3.36 (E), |error| <= 2e-8 for 0 <= m < 1:
# X(m) = sum_i c_i m1^i + ln(1/m1) sum_i d_i m1^i, m1 = 1 - m.
_K_POLY = (1.38629436112, 0.09666344259, 0.03590092383, 0.03742563713, 0.01451196212)
_K_LOG_POLY = (0.5, 0.12498593597, 0.06880248576, 0.03328355346, 0.00441787012)
_E_POLY = (1.0, 0.44325141463, 0.06260601220, 0.04757383546, 0.01736506451)
_E_LOG_POLY = (0.0, 0.24998368310, 0.09200180037, 0.04069697526, 0.00526449639)


class HertzContact(NamedTuple):
    """Dimensions and stiffness of one or many Hertz elliptical contacts (arrays, SI units).

    Attributes:
        semi_axis_x: contact-ellipse semi-axis along the rolling direction x [m].
        semi_axis_y: contact-ellipse semi-axis along the transverse direction y [m].
        approach: delta, mutual approach of distant points of the two bodies [m].
        max_pressure: p0 = 3 F / (2 pi a_x a_y), pressure at the ellipse centre [Pa].
        mean_pressure: F / (pi a_x a_y) = (2/3) p0 [Pa].
        area: pi a_x a_y [m^2].
        stiffness: K_H such that F = K_H delta^1.5 [N m^-1.5].
    """

    semi_axis_x: FloatArray
    semi_axis_y: FloatArray
    approach: FloatArray
    max_pressure: FloatArray
    mean_pressure: FloatArray
    area: FloatArray
    stiffness: FloatArray


class _EllipseShape(NamedTuple):
    """Load-independent shape of the contact ellipse (private helper of this module)."""

    ratio: FloatArray  # k = major / minor semi-axis >= 1
    ell_k: FloatArray  # K(m), m = 1 - 1/k^2
    ell_e: FloatArray  # E(m)
    curvature_sum: FloatArray  # A + B = 1 / R_e [1/m]
    major_along_x: NDArray[np.bool_]  # True where R_x > R_y


def _f64(value: ArrayLike) -> FloatArray:
    """``value`` as a float64 ndarray (0-d for a scalar), the return type of every function."""
    return np.asarray(value, dtype=np.float64)


def _polyval(x: FloatArray, coefficients: tuple[float, ...]) -> FloatArray:
    """sum_i c_i x^i for at least two coefficients c_0, c_1, ..., by Horner's rule."""
    result = coefficients[-1] * x + coefficients[-2]
    for coefficient in coefficients[-3::-1]:
        result = result * x + coefficient
    return _f64(result)


def _compliance(young_modulus: ArrayLike, poisson_ratio: ArrayLike) -> FloatArray:
    """(1 - nu^2) / E of one body [1/Pa] (Johnson 1985 section 4.2; paper Eq. 21)."""
    return _f64((1.0 - np.square(poisson_ratio)) / _f64(young_modulus))


def effective_modulus(E1: ArrayLike, nu1: ArrayLike, E2: ArrayLike, nu2: ArrayLike) -> FloatArray:  # noqa: N803
    """Hertz contact modulus E* [Pa] of two elastic bodies.

    1/E* = (1 - nu1^2)/E1 + (1 - nu2^2)/E2 (Johnson 1985, section 4.2), with Young's moduli E1, E2
    [Pa] and Poisson's ratios nu1, nu2 [-]. This is the E* of every Hertz formula in this module
    (steel/steel with E = 210 GPa, nu = 0.29: E* = 114.64 GPa). It is NOT the E' of the EHL film
    formulas, see :func:`reduced_modulus_ehl`.
    """
    return _f64(1.0 / (_compliance(E1, nu1) + _compliance(E2, nu2)))


def reduced_modulus_ehl(E1: ArrayLike, nu1: ArrayLike, E2: ArrayLike, nu2: ArrayLike) -> FloatArray:  # noqa: N803
    """Reduced modulus E' = 2 E* [Pa] used by the EHL film-thickness formulas.

    2/E' = (1 - nu1^2)/E1 + (1 - nu2^2)/E2 (Hamrock and Dowson's convention), i.e. E' is twice
    the Hertz E* of :func:`effective_modulus`. The paper's Eqs. (27)-(29) write E* but mean E'
    (MODEL_NOTES section 1): 229.28 GPa for the paper's steel, against E* = 114.64 GPa.
    """
    return _f64(2.0 * effective_modulus(E1, nu1, E2, nu2))


def complete_elliptic_integrals(m: ArrayLike) -> tuple[FloatArray, FloatArray]:
    """Complete elliptic integrals (K(m), E(m)) of parameter m, 0 <= m < 1 [-].

    K(m) = int_0^{pi/2} (1 - m sin^2 t)^(-1/2) dt, E(m) = int_0^{pi/2} (1 - m sin^2 t)^(1/2) dt,
    the parameter convention of scipy.special.ellipk/ellipe (m = e^2, e the eccentricity of the
    contact ellipse). Polynomial-logarithmic approximations of Abramowitz and Stegun (1972)
    17.3.34 and 17.3.36 in m1 = 1 - m, absolute error <= 2e-8; explicit and vectorised.
    """
    m1 = 1.0 - _f64(m)
    log_term = -np.log(m1)
    ell_k = _polyval(m1, _K_POLY) + log_term * _polyval(m1, _K_LOG_POLY)
    ell_e = _polyval(m1, _E_POLY) + log_term * _polyval(m1, _E_LOG_POLY)
    return _f64(ell_k), _f64(ell_e)


def ellipticity_antoine(R_x: ArrayLike, R_y: ArrayLike) -> FloatArray:  # noqa: N803
    """Contact-ellipse semi-axis ratio k = major / minor >= 1 [-] (Antoine et al. 2006).

    The major axis lies along the direction with the LARGER effective radius (smaller curvature):
    along y when R_y > R_x, along x when R_x > R_y. With the curvature ratio
    r = B/A = max(R_x, R_y) / min(R_x, R_y) >= 1 (radii R_x, R_y [m], both > 0), Antoine's
    explicit approximation of the exact Hertz relation (Johnson 1985 Eq. 4.39) is

        k = r^p,   p = (2/3) N(q) / D(q),   q = (log10 r)^2,

    with N, D quartic polynomials in q (coefficients in ``_ANTOINE_NUMERATOR`` and
    ``_ANTOINE_DENOMINATOR``); r = 1 gives k = 1 exactly.
    """
    r_x = _f64(R_x)
    r_y = _f64(R_y)
    curvature_ratio = np.maximum(r_x, r_y) / np.minimum(r_x, r_y)
    q = np.square(np.log10(curvature_ratio))
    exponent = (2.0 / 3.0) * (_polyval(q, _ANTOINE_NUMERATOR) / _polyval(q, _ANTOINE_DENOMINATOR))
    return _f64(curvature_ratio**exponent)


def _ellipse_shape(r_x: FloatArray, r_y: FloatArray) -> _EllipseShape:
    """Ellipse ratio, elliptic integrals and curvature sum of contacts with radii r_x, r_y [m]."""
    ratio = ellipticity_antoine(r_x, r_y)
    ell_k, ell_e = complete_elliptic_integrals(1.0 - ratio**-2)
    curvature_sum = 0.5 * (1.0 / r_x + 1.0 / r_y)
    return _EllipseShape(ratio, ell_k, ell_e, _f64(curvature_sum), np.asarray(r_x > r_y))


def _stiffness(shape: _EllipseShape, e_star: FloatArray) -> FloatArray:
    """K_H = eps(k) (4/3) E* sqrt(R_e) [N m^-1.5] of a contact of known shape (module docstring)."""
    eccentricity_factor = np.pi * shape.ratio * np.sqrt(shape.ell_e) / (2.0 * shape.ell_k**1.5)
    return _f64(eccentricity_factor * (4.0 / 3.0) * e_star / np.sqrt(shape.curvature_sum))


def _contact_from_minor_axis(
    minor: FloatArray, shape: _EllipseShape, e_star: FloatArray
) -> HertzContact:
    """Every contact quantity from the minor semi-axis b [m] (Johnson 1985 Eqs. 4.36-4.38).

    a = k b, p0 = E* (A + B) b / E(m), delta = (A + B) b^2 K(m) / E(m), area = pi a b,
    mean pressure = (2/3) p0. Finite and zero (stiffness excepted) for b = 0.
    """
    major = shape.ratio * minor
    max_pressure = e_star * shape.curvature_sum * minor / shape.ell_e
    return HertzContact(
        semi_axis_x=_f64(np.where(shape.major_along_x, major, minor)),
        semi_axis_y=_f64(np.where(shape.major_along_x, minor, major)),
        approach=_f64(shape.curvature_sum * np.square(minor) * shape.ell_k / shape.ell_e),
        max_pressure=_f64(max_pressure),
        mean_pressure=_f64((2.0 / 3.0) * max_pressure),
        area=_f64(np.pi * major * minor),
        stiffness=_stiffness(shape, e_star),
    )


def hertz_stiffness(R_x: ArrayLike, R_y: ArrayLike, E_star: ArrayLike) -> FloatArray:  # noqa: N803
    """Hertz stiffness K_H [N m^-1.5] such that F = K_H delta^1.5 (paper Eq. 18).

    K_H = eps(k) (4/3) E* sqrt(R_e), R_e = 2 / (1/R_x + 1/R_y) [m],
    eps(k) = pi k sqrt(E(m)) / (2 K(m)^1.5), m = 1 - 1/k^2, k from :func:`ellipticity_antoine`
    (derivation from Johnson 1985 Eqs. 4.36-4.39 in the module docstring; eps = 1 for a circle).
    R_x, R_y: effective radii of curvature [m], > 0; E_star: contact modulus E* [Pa].
    Explicit; cheap enough to evaluate every step.
    """
    return _stiffness(_ellipse_shape(_f64(R_x), _f64(R_y)), _f64(E_star))


def hertz_contact(
    F_n: ArrayLike,  # noqa: N803
    R_x: ArrayLike,  # noqa: N803
    R_y: ArrayLike,  # noqa: N803
    E_star: ArrayLike,  # noqa: N803
) -> HertzContact:
    """Hertz elliptical contact under normal load F_n [N] (explicit, Antoine et al. 2006).

    Minor semi-axis b^3 = 3 F E(m) / (2 pi k E* (A + B)) with A + B = (1/R_x + 1/R_y) / 2, then
    every quantity as in :class:`HertzContact` (Johnson 1985 Eqs. 4.36-4.39). R_x, R_y: effective
    radii of curvature [m], > 0; E_star: contact modulus E* [Pa] (:func:`effective_modulus`).
    F_n <= 0 is treated as 0: zero dimensions, approach and pressures, finite stiffness. All
    fields have the broadcast shape of the inputs.
    """
    force, r_x, r_y, e_star = np.broadcast_arrays(_f64(F_n), _f64(R_x), _f64(R_y), _f64(E_star))
    shape = _ellipse_shape(r_x, r_y)
    minor = np.cbrt(
        3.0
        * np.maximum(force, 0.0)
        * shape.ell_e
        / (2.0 * np.pi * shape.ratio * e_star * shape.curvature_sum)
    )
    return _contact_from_minor_axis(_f64(minor), shape, e_star)


def contact_from_approach(
    delta: ArrayLike,
    R_x: ArrayLike,  # noqa: N803
    R_y: ArrayLike,  # noqa: N803
    E_star: ArrayLike,  # noqa: N803
) -> HertzContact:
    """Hertz elliptical contact at a given approach delta [m] (the dynamic model's input).

    Minor semi-axis b = sqrt(delta E(m) / ((A + B) K(m))) (Johnson 1985 Eq. 4.38 with 4.36-4.37);
    the normal force is F = K_H delta^1.5 = (2/3) pi a b p0. R_x, R_y [m] > 0, E_star [Pa].
    delta <= 0 (no interpenetration, paper Eq. 17) gives zero dimensions and a finite stiffness.
    """
    approach, r_x, r_y, e_star = np.broadcast_arrays(
        _f64(delta), _f64(R_x), _f64(R_y), _f64(E_star)
    )
    shape = _ellipse_shape(r_x, r_y)
    minor = np.sqrt(np.maximum(approach, 0.0) * shape.ell_e / (shape.curvature_sum * shape.ell_k))
    return _contact_from_minor_axis(_f64(minor), shape, e_star)


def normal_force(
    delta: ArrayLike,
    delta_rate: ArrayLike,
    K_H: ArrayLike,  # noqa: N803
    b_h: ArrayLike,
) -> FloatArray:
    """Normal contact force [N] with saturated hysteresis damping (paper Eqs. 18-19, D14).

        F = K_H delta^1.5 + K_H delta^1.5 tanh(C_H (d delta/dt) / (K_H delta^1.5)),
        C_H = b_h sqrt(K_H).

    The paper saturates the damping with min(C_H |d delta/dt|, K_H delta^1.5): the tanh has the
    same slope C_H at zero rate and the same bound (the total force stays in [0, 2 K_H
    delta^1.5], no attraction on release) without the kink that stalls an implicit step.

    delta: approach (interpenetration) [m], no contact and F = 0 where delta <= 0;
    delta_rate: d delta/dt [m/s], positive while the bodies approach;
    K_H: Hertz stiffness [N m^-1.5]; b_h: damping proportionality coefficient
    [N s m^-1 (N m^-1.5)^-0.5 = N^0.5 s m^-0.25 = kg^0.5 m^0.25], so that C_H is in N s m^-1.
    """
    rate = _f64(delta_rate)
    stiffness = _f64(K_H)
    elastic = stiffness * np.maximum(_f64(delta), 0.0) ** 1.5
    viscous = _f64(b_h) * np.sqrt(stiffness) * rate
    # Smooth saturation (docs/model.md, D14): elastic * tanh(C_H rate / elastic) has slope C_H
    # at zero rate and magnitude below the elastic force, as min(C_H |rate|, elastic) has, but
    # no kink, which the dynamic model's implicit step needs.
    safe = np.where(elastic > 0.0, elastic, 1.0)
    # an elastic force near the underflow limit (delta below ~1e-211 m) makes the ratio overflow
    # to +-inf, whose tanh is the saturated +-1 the law asks for: not an error
    with np.errstate(over="ignore"):
        ratio = viscous / safe
    damping = np.where(elastic > 0.0, elastic * np.tanh(ratio), 0.0)
    return _f64(elastic + damping)


def deformation_split(
    delta: ArrayLike,
    E_ball: ArrayLike,  # noqa: N803
    nu_ball: ArrayLike,
    E_groove: ArrayLike,  # noqa: N803
    nu_groove: ArrayLike,
) -> tuple[FloatArray, FloatArray]:
    """Split the approach delta [m] into the sphere's and the groove's deformation (Eqs. 20-21).

    delta = delta_ball + delta_groove (Eq. 20) and
    delta_groove / delta_ball = ((1 - nu_g^2) E_b) / ((1 - nu_b^2) E_g) (Eq. 21), i.e. each body
    takes the share of delta proportional to its compliance (1 - nu^2)/E. Young's moduli E [Pa],
    Poisson's ratios nu [-]. Linear in delta (a negative delta is split too). Returns
    (delta_ball, delta_groove) [m].
    """
    approach = _f64(delta)
    ball = _compliance(E_ball, nu_ball)
    groove = _compliance(E_groove, nu_groove)
    total = ball + groove
    return _f64(approach * (ball / total)), _f64(approach * (groove / total))
