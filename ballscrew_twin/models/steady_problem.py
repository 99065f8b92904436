"""The steady model's problem: the spheres solved, their loads, scales and first guess.

Pure functions of the parameter set and the contact scene, shared by the readable and the
compiled Newton and by the cold-start paths: the spheres of a mode (:func:`make_ball_set`) and
the averaged problem (:func:`averaged_ball_set`), the axial load on each nut
(:func:`nut_axial_loads`), the scales of the residual rows (:func:`residual_scales`), the Hertz
and pure-rolling first guess (:func:`initial_state`), the spheres' d'Alembert terms
(:func:`inertial_actions`), gravity's power (:func:`potential_energy_rate`), the note on
sphere spacing (:func:`spacing_notes`) and the hint on a nearly unloaded nut
(:func:`unloaded_nut`). Units: SI (m, rad/s, N, W).
"""

from __future__ import annotations

import math
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from ..params import TwinConfig
from ..physics import geometry, hertz
from ..physics.contact_types import ContactScene
from .base import OperatingPoint
from .steady_types import BallSet, SteadyState

FloatArray = NDArray[np.float64]


def make_ball_set(config: TwinConfig, mode: Literal["symmetric", "full"]) -> BallSet:
    """Spheres to solve in ``mode`` (symmetric: one per nut standing for all of it; full: every
    sphere), their azimuths [rad] and gravity in their Frenet frames [m/s^2]."""
    screw = config.screw
    g = config.environment.gravity
    z_count = screw.balls_per_nut
    if mode == "symmetric":
        nut = np.array([0, 1])
        azimuth = np.zeros(2)
        weight = np.full(2, float(z_count))
    else:
        spacing = 2.0 * math.pi * screw.loaded_turns / z_count
        per_nut = np.arange(z_count) * spacing
        nut = np.repeat(np.array([0, 1]), z_count)
        azimuth = np.concatenate([per_nut, per_nut])
        weight = np.ones(2 * z_count)
    frames = geometry.frenet_frame(azimuth, screw.helix_angle)  # (B, 3, 3) rows t, n, b
    if screw.orientation == "vertical":
        g_world = np.array([0.0, 0.0, -g])  # screw axis z points up
    else:
        g_world = np.array([0.0, -g, 0.0])  # horizontal axis, gravity along -y
    gravity = np.einsum("bij,j->bi", frames, g_world)
    return BallSet(nut=nut, azimuth=azimuth, weight=weight, gravity=gravity)


def averaged_ball_set(balls: BallSet) -> BallSet:
    """One sphere per nut standing for all of it, under the mean of its spheres' gravity
    (in Frenet components): the symmetric problem closest to ``balls`` (on a vertical screw
    every sphere's gravity is that mean, and the problem is the symmetric one)."""
    nut = np.array([0, 1])
    weight = np.array([float(np.sum(balls.weight[balls.nut == k])) for k in (0, 1)])
    gravity = np.stack([np.mean(balls.gravity[balls.nut == k], axis=0) for k in (0, 1)])
    return BallSet(nut=nut, azimuth=np.zeros(2), weight=weight, gravity=gravity)


def nut_axial_loads(config: TwinConfig, op: OperatingPoint) -> FloatArray:
    """Force the spheres must exert on each nut along +z [N] (master, slave).

    The preload pushes the master nut up and the slave nut down (paper: preload force between
    the nuts); each nut's weight pulls it down on a vertical screw; the external axial load
    acts on the master nut.
    """
    weight = config.screw.nut_mass * config.environment.gravity
    if config.screw.orientation != "vertical":
        weight = 0.0
    master = -(op.preload - weight + op.axial_load)
    slave = -(-op.preload - weight)
    return np.array([master, slave])


#: A nut whose spheres each carry less than this many times a sphere's weight along the axis is
#: named when a solve fails [-]. Measured (docs/model.md 7a, "Near the nut's weight"): the 32 mm
#: screw's solves fail where the preload is within 2-4 N of its nut's 8.3 N weight, up to 11
#: sphere weights per sphere.
UNLOADED_SPHERE_WEIGHTS = 12.0


def unloaded_nut(config: TwinConfig, op: OperatingPoint) -> str:
    """Why a solve at ``op`` may fail when a nut is nearly unloaded: a sentence naming the nut,
    its spheres' share of its axial load [N] and that share in sphere weights, or "" when
    every nut's spheres carry more than :data:`UNLOADED_SPHERE_WEIGHTS` sphere weights."""
    weight = config.ball_mass * config.environment.gravity
    count = config.screw.balls_per_nut
    for name, load in zip(("master", "slave"), nut_axial_loads(config, op), strict=True):
        share = abs(float(load)) / count
        if share < UNLOADED_SPHERE_WEIGHTS * weight:
            return (
                f"the {name} nut's spheres carry {share:.3g} N each along the axis, "
                f"{share / weight:.1f} times a sphere's weight (the preload {op.preload:g} N "
                "against the nut's weight and the axial load): nearly unloaded spheres, where "
                "the steady state is not solved (docs/model.md 7a)"
            )
    return ""


def initial_state(
    config: TwinConfig, scene: ContactScene, balls: BallSet, loads: FloatArray
) -> SteadyState:
    """Hertz estimate of the offsets and the pure-rolling estimate of the rates."""
    geom = scene.geometry
    r_b, r_s = geom.ball_radius, geom.groove_radius
    clearance = r_s - r_b
    b_touch = math.sqrt(max(clearance**2 - geom.centre_offset**2, 0.0)) - geom.ogival_offset
    alpha = geom.free_contact_angle
    per_ball = np.abs(loads) / config.screw.balls_per_nut
    q = per_ball / (math.sin(alpha) * math.cos(geom.helix_angle))
    k_roll, k_trans = geometry.principal_curvatures(geom, np.array([alpha]), np.array([0]))
    rx, ry = geometry.reduced_radii(r_b, k_roll, k_trans)
    stiffness = float(hertz.hertz_stiffness(rx, ry, scene.e_star)[0])
    delta = (q / stiffness) ** (2.0 / 3.0)
    # Nut pushed down by its spheres (load < 0) bears on S2/N1: ball and nut go +b.
    sign = np.where(loads < 0.0, 1.0, -1.0)
    ball_b = sign * (b_touch + delta / math.sin(alpha))
    nut_offset = sign * 2.0 * (b_touch + delta / math.sin(alpha))
    ball_nb = np.stack([np.zeros(len(balls.nut)), ball_b[balls.nut]], axis=-1)
    kin = np.zeros((len(balls.nut), 4))
    if scene.screw_speed != 0.0:
        kin = rolling_kinematics(scene, balls, ball_nb, nut_offset)
    return SteadyState(ball_nb, kin, nut_offset, scene.screw_speed)


def rolling_kinematics(
    scene: ContactScene, balls: BallSet, ball_nb: FloatArray, nut_offset: FloatArray
) -> FloatArray:
    """Rates that minimise the slips at the loaded contacts (least squares, per sphere)."""
    count = len(balls.nut)
    e_ball = nut_offset[balls.nut]
    geom = scene.geometry
    ratio = (geom.pitch_radius + geom.ball_radius * math.cos(geom.free_contact_angle)) / (
        2.0 * geom.pitch_radius
    )
    w_ball = -scene.screw_speed * ratio
    kin = np.zeros((count, 4))
    kin[:, 0] = w_ball
    # Rolling about the in-plane axis perpendicular to the contact line, no spin on the screw.
    alpha = geom.free_contact_angle
    speed = w_ball * geom.pitch_radius / math.cos(geom.helix_angle)
    # Pure rolling on the fixed screw: omega x (r_b d) = -v_centre t, i.e. omega =
    # (s, 0, 0) x d with s = speed / r_b and d = (0, cos a, +-sin a) (sign of e_ball).
    sign_b = np.where(e_ball > 0.0, 1.0, -1.0)
    spin_rate = speed / geom.ball_radius
    kin[:, 2] = -(spin_rate * (sign_b * math.sin(alpha)))
    kin[:, 3] = spin_rate * math.cos(alpha)
    return kin


def residual_scales(
    config: TwinConfig, scene: ContactScene, loads: FloatArray
) -> tuple[float, float]:
    """Scales of the residual rows: (force [N], moment [N m]), the larger of the load per
    sphere and its weight (at least 1e-6 N), times the sphere radius for the moment."""
    master, slave = loads.tolist()
    per_ball = max(abs(master), abs(slave)) / config.screw.balls_per_nut
    force = max(per_ball, scene.ball_mass * config.environment.gravity, 1e-6)
    return force, force * scene.geometry.ball_radius


def inertial_actions(
    scene: ContactScene, ball_nb: FloatArray, kinematics: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """d'Alembert terms of the orbiting spheres that the steady contact laws add (section 7).

    Centrifugal force m (Omega + w_B)^2 r_perp on the centre (r_perp its distance vector from
    the axis) and gyroscopic moment (Omega + w_B) z x I omega_abs, omega_abs = omega + Omega z,
    both in Frenet components; ``evaluate_contacts`` (steady use) adds the force and subtracts
    the moment.

    Args:
        scene: constants of the operating point (screw speed Omega [rad/s], sphere mass [kg]
            and inertia [kg m^2], geometry).
        ball_nb: (B, 2) ball-centre offsets (n, b) from the ideal helix [m].
        kinematics: (B, 4) orbital rate w_B and angular velocity (t, n, b) relative to the
            screw [rad/s].

    Returns:
        (centrifugal force (B, 3) [N], gyroscopic moment (B, 3) [N m]).
    """
    geom = scene.geometry
    zhat = geometry.axis_direction(geom.helix_angle)
    r_ball = np.stack(
        [np.zeros(len(ball_nb)), ball_nb[:, 0] - geom.pitch_radius, ball_nb[:, 1]], axis=-1
    )
    orbit_rate = scene.screw_speed + kinematics[:, 0]
    r_perp = r_ball - np.einsum("bi,i->b", r_ball, zhat)[:, None] * zhat
    centrifugal = (scene.ball_mass * orbit_rate**2)[:, None] * r_perp
    omega_abs = kinematics[:, 1:4] + scene.screw_speed * zhat
    gyroscopic = orbit_rate[:, None] * np.cross(zhat, scene.ball_inertia * omega_abs)
    return np.asarray(centrifugal), np.asarray(gyroscopic)


def nut_gravity_power(config: TwinConfig, scene: ContactScene) -> float:
    """Gravity's power on the two nuts, moving at -Omega p/(2 pi) z [W] (vertical screw)."""
    if config.screw.orientation != "vertical":
        return 0.0
    lead_rate = scene.geometry.lead / (2.0 * math.pi)
    g = config.environment.gravity
    return 2.0 * config.screw.nut_mass * g * scene.screw_speed * lead_rate


def potential_energy_rate(
    config: TwinConfig, scene: ContactScene, balls: BallSet, state: SteadyState
) -> float:
    """Rate of change of the gravitational energy of spheres and nuts [W].

    Sphere i moves with v = w_B (z x r + p/(2 pi) z) relative to the screw plus
    Omega z x r; each nut with -Omega p/(2 pi) z. On a horizontal screw the spheres' share
    does not vanish (1.75 turns are not a whole number), on a vertical one the nuts' weight
    dominates.
    """
    geom = scene.geometry
    lead_rate = geom.lead / (2.0 * math.pi)
    z_t, _, z_b = geometry.axis_direction(geom.helix_angle)  # z has no n-component
    r_n = state.ball_nb[:, 0] - geom.pitch_radius  # centre from the axis: (0, r_n, b)
    r_b = state.ball_nb[:, 1]
    w_ball = state.kinematics[:, 0]
    orbit_rate = w_ball + scene.screw_speed
    along = w_ball * lead_rate
    # v = (w_B + Omega) z x r + w_B p/(2 pi) z, z x r = (-z_b r_n, -z_t r_b, z_t r_n).
    acc = balls.gravity
    g_dot_v = (
        acc[:, 0] * (orbit_rate * (-z_b * r_n) + along * z_t)
        + acc[:, 1] * (orbit_rate * (-z_t * r_b))
        + acc[:, 2] * (orbit_rate * (z_t * r_n) + along * z_b)
    )
    balls_power = scene.ball_mass * float(np.sum(balls.weight * g_dot_v))
    return -(balls_power + nut_gravity_power(config, scene))


def spacing_notes(config: TwinConfig, scene: ContactScene) -> list[str]:
    """Sphere-to-sphere contact is skipped when equally spaced spheres cannot touch."""
    geom = config.screw
    length = 2.0 * math.pi * geom.pitch_radius * geom.loaded_turns / math.cos(geom.helix_angle)
    gap = length / geom.balls_per_nut - 2.0 * scene.geometry.ball_radius
    if gap > 0.0:
        return [f"sphere-to-sphere contacts skipped: equal spacing leaves {gap * 1e3:.3f} mm"]
    return ["spheres are packed without gap: sphere-to-sphere contact not resolved here"]
