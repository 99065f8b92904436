"""Exact Hertz elliptical contact: the test oracle of :mod:`ballscrew_twin.physics.hertz`.

Slow, scalar and iterative on purpose; used only by the tests. Notation of Johnson, "Contact
Mechanics" (1985), section 4.2: relative curvatures A <= B (A = 1/(2 R_max), B = 1/(2 R_min)),
major semi-axis a along the direction of curvature A, minor semi-axis b, ellipse ratio
k = a/b >= 1, eccentricity e = sqrt(1 - 1/k^2), maximum pressure p0, load F = (2/3) pi a b p0.
Johnson's Eqs. (4.36)-(4.39):

    A = (p0 / E*) b / (e^2 a^2) [K - E]
    B = (p0 / E*) b / (e^2 a^2) [(a^2/b^2) E - K]
    delta = (p0 / E*) b K
    B/A = [(a/b)^2 E - K] / [K - E]

K, E are the complete elliptic integrals. Johnson writes them of the modulus e; scipy's
ellipk/ellipe take the parameter m = e^2 and scipy.special.ellipkm1 takes m1 = 1 - m = 1/k^2.
The difference K - E cancels for nearly circular contacts, so it is evaluated as
K - E = m D with D = R_D(0, m1, 1) / 3 (Carlson's symmetric integral, DLMF 19.25.1,
scipy.special.elliprd). With E - m1 K = m (K - D) the ratio becomes

    B/A = (K - D) / (m1 D),

solved for k with brentq on ln k. The route to the dimensions deliberately differs from the
module's: p0 = 3F / (2 pi a b) eliminated from the A equation gives a^3 = 3 F D / (2 pi E* A);
then b = a/k, p0 from the load, delta from the third equation and K_H = F / delta^1.5.
"""

from __future__ import annotations

import math
from typing import NamedTuple

from scipy.optimize import brentq
from scipy.special import ellipkm1, elliprd

# Below this B/A - 1 the first-order expansion B/A = 1 + (3/4) e^2 of Johnson's Eq. (4.39) about
# the circle is exact to ~1e-20 in e^2, and brentq would only see rounding noise.
_NEAR_CIRCLE = 1e-10


class ExactContact(NamedTuple):
    """The fields of ``ballscrew_twin.physics.hertz.HertzContact``, as floats (same SI units)."""

    semi_axis_x: float
    semi_axis_y: float
    approach: float
    max_pressure: float
    mean_pressure: float
    area: float
    stiffness: float


def _elliptic_terms(semi_axis_ratio: float) -> tuple[float, float, float]:
    """(K, D = (K - E)/m, m1 = 1 - m) for the ellipse ratio k >= 1, exact via scipy."""
    m1 = semi_axis_ratio**-2
    return float(ellipkm1(m1)), float(elliprd(0.0, m1, 1.0)) / 3.0, m1


def curvature_ratio(semi_axis_ratio: float) -> float:
    """B/A of Johnson's Eq. (4.39) for the ellipse ratio k = a/b >= 1 (exact)."""
    ell_k, ell_d, m1 = _elliptic_terms(semi_axis_ratio)
    return (ell_k - ell_d) / (m1 * ell_d)


def exact_semi_axis_ratio(ratio_b_over_a: float) -> float:
    """Ellipse ratio k = a/b >= 1 solving Johnson's Eq. (4.39) for a given B/A >= 1."""
    if ratio_b_over_a - 1.0 <= _NEAR_CIRCLE:
        return 1.0 / math.sqrt(1.0 - (4.0 / 3.0) * (ratio_b_over_a - 1.0))
    log_r = math.log(ratio_b_over_a)
    # The exact exponent ln k / ln(B/A) lies between 0.59 and 2/3 for B/A <= 1e4: bracket widely.
    log_k = brentq(
        lambda s: curvature_ratio(math.exp(s)) - ratio_b_over_a,
        0.1 * log_r,
        log_r,
        xtol=1e-15,
    )
    return math.exp(log_k)


def exact_hertz(force: float, r_x: float, r_y: float, e_star: float) -> ExactContact:
    """Exact Hertz contact for load force > 0 [N], radii r_x, r_y > 0 [m], modulus E* [Pa]."""
    curv_min = 1.0 / (2.0 * max(r_x, r_y))  # A
    curv_max = 1.0 / (2.0 * min(r_x, r_y))  # B
    k = exact_semi_axis_ratio(curv_max / curv_min)
    ell_k, ell_d, _ = _elliptic_terms(k)
    major = (3.0 * force * ell_d / (2.0 * math.pi * e_star * curv_min)) ** (1.0 / 3.0)
    minor = major / k
    max_pressure = 3.0 * force / (2.0 * math.pi * major * minor)
    approach = max_pressure * minor * ell_k / e_star
    major_along_x = r_x > r_y
    return ExactContact(
        semi_axis_x=major if major_along_x else minor,
        semi_axis_y=minor if major_along_x else major,
        approach=approach,
        max_pressure=max_pressure,
        mean_pressure=force / (math.pi * major * minor),
        area=math.pi * major * minor,
        stiffness=force / approach**1.5,
    )
