"""Ball-screw geometry in the Frenet frame of the ball-centre helix (paper section 2.1).

Vectors are numpy arrays with the last axis (t, n, b): t along the helix, n the principal normal
(pointing towards the screw axis), b = t x n the binormal (nearly axial). The contact problem is
reduced to the normal (n, b) plane, as in the paper (Eqs. 1-8).

Half grooves are numbered 0..3 = S1, S2, N1, N2. Their curvature centres relative to the ideal
ball centre B (Eq. 7 for S1) are

    S1 (-H, +L)   S2 (-H, -L)   N1 (+H, +L + e)   N2 (+H, -L + e)       [(n, b), m]

with e the axial (b) offset of the nut groove. A ball touches S1 and N1 on its lower (-b) side
and S2 and N2 on its upper side; a loaded ball of the master nut (pushed up, +z) bears on S2 and
N1, one of the slave nut (pushed down) on S1 and N2.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..params import Materials, ScrewGeometry

FloatArray = NDArray[np.float64]

S1, S2, N1, N2 = 0, 1, 2, 3
HALF_GROOVE_NAMES = ("S1", "S2", "N1", "N2")
#: +1 for the screw half grooves (contact towards the axis), -1 for the nut ones.
SIDE_N = np.array([1.0, 1.0, -1.0, -1.0])
#: -1 where the contact lies on the ball's -b side (S1, N1), +1 on its +b side (S2, N2).
SIDE_B = np.array([-1.0, 1.0, -1.0, 1.0])
IS_NUT = np.array([False, False, True, True])
#: Temperature at which the catalogue dimensions hold (ISO 1) [K].
DIMENSION_REFERENCE_TEMPERATURE = 293.15


def axis_direction(helix_angle: float) -> FloatArray:
    """Unit vector of the screw axis z in Frenet components (t, n, b) = (sin l, 0, cos l)."""
    return np.array([math.sin(helix_angle), 0.0, math.cos(helix_angle)])


def frenet_frame(azimuth: ArrayLike, helix_angle: float) -> FloatArray:
    """Rows t, n, b of the Frenet frame at azimuth theta, in screw coordinates (x, y, z).

    This is T_BO of the paper (a vector in Oxyz times T_BO gives its Frenet components), for the
    right-handed helix R_B/O = r_m (cos theta, sin theta, theta tan l) of Eq. 2.

    Args:
        azimuth: theta [rad], any shape S.
        helix_angle: l [rad].

    Returns:
        Array of shape S + (3, 3).
    """
    th = np.asarray(azimuth, dtype=np.float64)
    c, s = np.cos(th), np.sin(th)
    cl, sl = math.cos(helix_angle), math.sin(helix_angle)
    zero = np.zeros_like(th)
    t = np.stack([-s * cl, c * cl, np.full_like(th, sl)], axis=-1)
    n = np.stack([-c, -s, zero], axis=-1)
    b = np.stack([s * sl, -c * sl, np.full_like(th, cl)], axis=-1)
    return np.stack([t, n, b], axis=-2)


def half_groove_centres(geom: ScrewGeometry, nut_offset: ArrayLike) -> FloatArray:
    """(n, b) coordinates of the curvature centres of S1, S2, N1, N2 relative to B (Eq. 7) [m].

    Args:
        geom: screw geometry.
        nut_offset: e, offset of the nut groove along b, shape S [m].

    Returns:
        Array of shape S + (4, 2).
    """
    e = np.asarray(nut_offset, dtype=np.float64)
    h, ell = geom.centre_offset, geom.ogival_offset
    base = np.array([[-h, ell], [-h, -ell], [h, ell], [h, -ell]])
    centres = np.broadcast_to(base, (*e.shape, 4, 2)).copy()
    centres[..., 2:, 1] += e[..., None]
    return centres


def contact_geometry(
    ball_nb: ArrayLike, centres: ArrayLike, ball_radius: float, groove_radius: ArrayLike
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Approach, common normal and contact angle of a ball with each half groove (Eqs. 5-8, 17).

    Args:
        ball_nb: (n, b) position of the ball centre F relative to B, shape S + (2,) [m].
        centres: half-groove centres, shape S + (4, 2) [m].
        ball_radius: r_b [m].
        groove_radius: r_s of each half groove, broadcastable to S + (4,) [m].

    Returns:
        approach: delta = |R_F/C| + r_b - r_s, positive when in contact, shape S + (4,) [m].
        normal: unit vector d from the groove centre C through F, (n, b) components,
            shape S + (4, 2); the contact point lies at F + r_b d.
        contact_angle: alpha = atan2(s_b d_b, s_n d_n), shape S + (4,) [rad].
    """
    rel = np.asarray(ball_nb, dtype=np.float64)[..., None, :] - np.asarray(centres)
    dist = np.hypot(rel[..., 0], rel[..., 1])
    normal = rel / np.maximum(dist, 1e-30)[..., None]
    approach = dist + ball_radius - np.asarray(groove_radius)
    angle = np.arctan2(SIDE_B * normal[..., 1], SIDE_N * normal[..., 0])
    return approach, normal, angle


def contact_exists(
    approach: ArrayLike, contact_angle: ArrayLike, inner_angle: float, outer_angle: float
) -> NDArray[np.bool_]:
    """Contact existence conditions of Eq. 22: interpenetration and DCA_i <= alpha <= DCA_o.

    The condition R . n >= 0 of Eq. 22 (ball centre on the groove's own side) is contained in
    the angle window, since alpha is measured from the half groove's own n direction.
    """
    alpha = np.asarray(contact_angle)
    return np.asarray(
        (np.asarray(approach) > 0.0) & (alpha >= inner_angle) & (alpha <= outer_angle)
    )


def principal_curvatures(
    geom: ScrewGeometry, contact_angle: ArrayLike, half_groove: ArrayLike
) -> tuple[FloatArray, FloatArray]:
    """Groove surface curvatures at the contact point [1/m] (positive = convex).

    Rolling direction (Meusnier, MODEL_NOTES section 3): screw cos(a) cos^2(l) / (r_m - r_b cos a),
    nut -cos(a) cos^2(l) / (r_m + r_b cos a); transverse -1/r_s on both.

    Returns:
        (curvature along t, curvature across t in the normal plane).
    """
    alpha = np.asarray(contact_angle, dtype=np.float64)
    nut = IS_NUT[np.asarray(half_groove)]
    cos_a = np.cos(alpha)
    cl2 = math.cos(geom.helix_angle) ** 2
    radius = geom.pitch_radius + np.where(nut, 1.0, -1.0) * geom.ball_radius * cos_a
    rolling = np.where(nut, -1.0, 1.0) * cos_a * cl2 / radius
    transverse = np.full_like(rolling, -1.0 / geom.groove_radius)
    return np.asarray(rolling), np.asarray(transverse)


def reduced_radii(
    ball_radius: float, groove_rolling: ArrayLike, groove_transverse: ArrayLike
) -> tuple[FloatArray, FloatArray]:
    """Reduced radii R_x = 1/(1/r_b + k_t), R_y = 1/(1/r_b + k_y) of ball and groove [m]."""
    rx = 1.0 / (1.0 / ball_radius + np.asarray(groove_rolling))
    ry = 1.0 / (1.0 / ball_radius + np.asarray(groove_transverse))
    return np.asarray(rx), np.asarray(ry)


def thermally_expanded(
    geom: ScrewGeometry, materials: Materials, temperature: float
) -> ScrewGeometry:
    """Geometry at ``temperature`` [K] from free thermal expansion of each body.

    Ball radius scales with the ball's coefficient; pitch radius, lead, groove offsets and the
    groove radius with the screw's. With equal coefficients the whole screw scales uniformly,
    conformity and angles unchanged. The nut's own expansion is not resolved separately (one
    groove radius): the difference to the screw's coefficient is reported by
    :func:`nut_expansion_mismatch`.
    """
    dt = temperature - DIMENSION_REFERENCE_TEMPERATURE
    ball = 1.0 + materials.ball.thermal_expansion * dt
    screw = 1.0 + materials.screw.thermal_expansion * dt
    ball_radius = geom.ball_radius * ball
    groove_radius = geom.groove_radius * screw
    return replace(
        geom,
        pitch_radius=geom.pitch_radius * screw,
        lead=geom.lead * screw,
        ball_radius=ball_radius,
        centre_offset=geom.centre_offset * screw,
        ogival_offset=geom.ogival_offset * screw,
        conformity=groove_radius / (2.0 * ball_radius),
    )


def nut_expansion_mismatch(materials: Materials, temperature: float) -> float:
    """Relative strain between nut and screw at ``temperature`` [-] (0 for equal materials)."""
    dt = temperature - DIMENSION_REFERENCE_TEMPERATURE
    return (materials.nut.thermal_expansion - materials.screw.thermal_expansion) * dt
