"""Sphere-to-sphere contact: closed-form Hertz of two equal spheres, action-reaction, friction."""

import math

import numpy as np
import pytest

from ballscrew_twin.models.contact_forces import make_scene
from ballscrew_twin.models.sphere_contact import sphere_pair_contact
from ballscrew_twin.params import load_config

SCENE = make_scene(load_config(), 293.15, 10.0)
R = float(SCENE.geometry.ball_radius)  # type: ignore[attr-defined]


def pair(
    delta: float,
    vel_b: tuple[float, float, float] = (0, 0, 0),
    omega_a: tuple[float, float, float] = (0, 0, 0),
):  # type: ignore[no-untyped-def]
    zeros = np.zeros((1, 3))
    return sphere_pair_contact(
        SCENE,
        zeros,
        np.array([[2 * R - delta, 0.0, 0.0]]),
        zeros,
        np.array([vel_b]),
        np.array([omega_a]),
        zeros,
    )


def test_static_force_is_closed_form_hertz_of_two_spheres() -> None:
    delta = 2e-6
    e_star = 210e9 / (2 * (1 - 0.29**2))
    expected = 4.0 / 3.0 * e_star * math.sqrt(R / 2) * delta**1.5  # Johnson eq. 4.22, R = r_b/2
    out = pair(delta)
    assert out.normal_force[0] == pytest.approx(expected, rel=1e-5)
    # Pushes a away from b (b lies along +x).
    assert out.force_on_a[0, 0] == pytest.approx(-expected, rel=1e-5)


def test_apart_spheres_exchange_nothing() -> None:
    out = pair(-1e-6, vel_b=(0.0, 0.3, 0.0))
    assert not out.in_contact[0]
    assert np.all(out.force_on_a == 0.0) and out.dissipation[0] == 0.0


def test_friction_opposes_slip_and_dissipates() -> None:
    # a spins about z: its surface at the contact (+x) moves along +y relative to b.
    out = pair(2e-6, omega_a=(0.0, 0.0, 50.0))
    assert out.friction_force[0] > 0.0
    assert out.force_on_a[0, 1] < 0.0  # friction on a against +y slip
    assert out.dissipation[0] > 0.0
    # Moment on a opposes its spin; the pair's moments and the force couple balance about a.
    assert out.moment_on_a[0, 2] < 0.0
    arm_ab = np.array([2 * R - 2e-6, 0.0, 0.0])
    total = out.moment_on_a[0] + out.moment_on_b[0] + np.cross(arm_ab, -out.force_on_a[0])
    np.testing.assert_allclose(total, 0.0, atol=1e-12)
