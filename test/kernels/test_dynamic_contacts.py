"""The dynamic path of the contact laws: arbitrary centre velocity, nut slide, damping.

The numba kernel against the numpy reference, and the reference against its own steady path
(a helical centre velocity must give the steady contact actions without the d'Alembert terms).
"""

import numpy as np
import pytest

from ballscrew_twin.kernels.contact_layout import N_STATICS
from ballscrew_twin.kernels.contacts import (
    contacts_kernel,
    contacts_kinetics_kernel,
    contacts_statics_kernel,
    evaluate_contacts_compiled,
    scene_arrays,
)
from ballscrew_twin.models.base import OperatingPoint
from ballscrew_twin.models.contact_forces import evaluate_contacts, make_scene
from ballscrew_twin.models.steady import SteadyStateModel
from ballscrew_twin.params import load_config

CONFIG = load_config()


@pytest.fixture(scope="module")
def solved():  # type: ignore[no-untyped-def]
    point = OperatingPoint(screw_speed=60.0, temperature=293.15, preload=1200.0)
    sol = SteadyStateModel(CONFIG, mode="full").solve(point)
    return sol, make_scene(CONFIG, point.temperature, point.screw_speed)


def helical_velocity(scene, sol):  # type: ignore[no-untyped-def]
    geom = scene.geometry
    zhat = np.array([np.sin(geom.helix_angle), 0.0, np.cos(geom.helix_angle)])
    r = np.stack(
        [
            np.zeros(len(sol.balls.nut)),
            sol.state.ball_nb[:, 0] - geom.pitch_radius,
            sol.state.ball_nb[:, 1],
        ],
        axis=-1,
    )
    field = np.cross(zhat, r) + geom.lead / (2 * np.pi) * zhat
    return sol.state.kinematics[:, :1] * field


def test_helical_velocity_reproduces_the_steady_contact_actions(solved) -> None:  # type: ignore[no-untyped-def]
    sol, scene = solved
    args = (
        scene,
        sol.state.ball_nb,
        sol.state.kinematics,
        sol.state.nut_offset[sol.balls.nut],
        sol.balls.gravity,
    )
    steady = evaluate_contacts(*args)
    dynamic = evaluate_contacts(*args, centre_velocity=helical_velocity(scene, sol))
    np.testing.assert_allclose(dynamic.groove_force, steady.groove_force, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(dynamic.slip, steady.slip, rtol=1e-9, atol=1e-15)
    # Dynamic forces are the contact actions: steady = dynamic + gravity + centrifugal.
    extra = steady.force - dynamic.force
    assert np.all(np.abs(extra) < 1e-2)  # m g + m Omega^2 r ~ 1e-3 N here
    assert np.any(np.abs(extra) > 0.0)


def test_kernel_matches_reference_on_dynamic_states(solved) -> None:  # type: ignore[no-untyped-def]
    sol, scene = solved
    rng = np.random.default_rng(7)
    count = len(sol.balls.nut)
    for _ in range(20):
        ball_nb = sol.state.ball_nb + rng.normal(0.0, 1e-6, (count, 2))
        kin = sol.state.kinematics * (1.0 + rng.normal(0.0, 0.05, (count, 4)))
        velocity = helical_velocity(scene, sol) + rng.normal(0.0, 2e-3, (count, 3))
        slide = rng.normal(0.0, 1e-3, count)
        args = (scene, ball_nb, kin, sol.state.nut_offset[sol.balls.nut], sol.balls.gravity)
        ref = evaluate_contacts(*args, centre_velocity=velocity, nut_slide=slide)
        fast = evaluate_contacts_compiled(*args, centre_velocity=velocity, nut_slide=slide)
        np.testing.assert_array_equal(fast.active, ref.active)
        for name in ("force", "moment", "groove_force", "groove_moment_z", "slip", "spin"):
            a, b = getattr(fast, name), getattr(ref, name)
            scale = np.max(np.abs(b)) + 1e-30
            np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-11 * scale, err_msg=name)


def test_damping_acts_only_while_approaching(solved) -> None:  # type: ignore[no-untyped-def]
    sol, scene = solved
    args = (
        scene,
        sol.state.ball_nb,
        sol.state.kinematics,
        sol.state.nut_offset[sol.balls.nut],
        sol.balls.gravity,
    )
    base = helical_velocity(scene, sol)
    still = evaluate_contacts(*args, centre_velocity=base)
    # Push the balls along +n (towards the screw): screw contacts approach, nut ones separate.
    push = base + np.array([0.0, 1e-3, 0.0])
    moving = evaluate_contacts(*args, centre_velocity=push)
    f_still = np.linalg.norm(still.groove_force, axis=-1)
    f_moving = np.linalg.norm(moving.groove_force, axis=-1)
    screw = still.active[:, :2]
    nut = still.active[:, 2:]
    assert np.all(f_moving[:, :2][screw] > f_still[:, :2][screw])
    assert np.all(f_moving[:, 2:][nut] < f_still[:, 2:][nut])


@pytest.mark.parametrize("defects", [False, True])
def test_statics_kept_over_a_step_give_the_kernel_bit_for_bit(solved, defects: bool) -> None:  # type: ignore[no-untyped-def]
    """contacts_statics_kernel once, then contacts_kinetics_kernel at several velocities and
    screw speeds: the same buffer as contacts_kernel's dynamic path at each (the split only
    reorders when the velocity-independent laws are evaluated)."""
    sol, scene = solved
    rng = np.random.default_rng(11)
    count = len(sol.balls.nut)
    p = np.array(scene_arrays(scene), dtype=np.float64)
    # Spread the spheres so that some contacts open (inactive ones must match too).
    ball_nb = np.ascontiguousarray(sol.state.ball_nb + rng.normal(0.0, 5e-6, (count, 2)))
    nut_offset = np.ascontiguousarray(sol.state.nut_offset[sol.balls.nut], dtype=np.float64)
    offsets = rng.normal(0.0, 2e-6, (count, 4)) if defects else np.zeros((0, 4))
    statics = np.empty((count, 4, N_STATICS))
    contacts_statics_kernel(ball_nb, nut_offset, offsets, p, statics)
    inactive = 0
    for _ in range(5):
        speed = scene.screw_speed * (1.0 + rng.normal(0.0, 0.1))
        omega = sol.state.kinematics[:, 1:] * (1.0 + rng.normal(0.0, 0.05, (count, 3)))
        velocity = helical_velocity(scene, sol) + rng.normal(0.0, 2e-3, (count, 3))
        slide = rng.normal(0.0, 1e-3, count)
        kin = np.zeros((count, 4))
        kin[:, 1:] = omega
        active, out = contacts_kernel(
            ball_nb, kin, nut_offset, np.zeros((count, 3)), velocity, slide, offsets, True,
            *p[:12], speed, *p[13:20], int(p[20]), *p[21:],
        )  # fmt: skip
        split_active, split_out = contacts_kinetics_kernel(
            statics, ball_nb, np.ascontiguousarray(omega), velocity, slide, p, speed
        )
        np.testing.assert_array_equal(split_active, active)
        np.testing.assert_array_equal(split_out, out)
        inactive += int(np.sum(~active))
    assert 0 < inactive < 5 * 4 * count
