"""Sphere-to-sphere contacts inside the dynamic step (neighbours along the helix).

Two spheres of one nut placed so that they interpenetrate by delta: the impulse the step gives
them (compared with the same step without sphere contacts) is the closed-form Hertz force of
two equal spheres, equal and opposite along their line of centres; and a frictionless,
undamped collision of two neighbours does not create energy.
"""

import dataclasses
import math

import numpy as np
import pytest

from ballscrew_twin.models.dynamic import DynamicModel
from ballscrew_twin.models.dynamic_state import Commands, DynamicState, SpeedController
from ballscrew_twin.params import TwinConfig, load_config

BASE = load_config()
PRELOAD = 300.0
STEPS = 70  # of 0.5 us: 4 us of approach, ~18 us of impact, then apart


def frictionless() -> TwinConfig:
    """Two spheres per nut, no friction of any kind, no damping."""
    screw = dataclasses.replace(BASE.screw, balls_per_nut=2)
    contact = dataclasses.replace(
        BASE.contact, dry_friction_coefficient=0.0, damping_coefficient=0.0
    )
    lub = dataclasses.replace(
        BASE.lubricant,
        limiting_shear_stress=0.0,
        limiting_shear_pressure_coefficient=0.0,
        viscosity_reference=1e-5,
        viscosity_second=5e-6,
    )
    return dataclasses.replace(BASE, screw=screw, contact=contact, lubricant=lub)


def neighbours(model: DynamicModel, gap: float) -> DynamicState:
    """Static preloaded state with sphere 1 of the master nut moved along the helix next to
    sphere 0, their centre distance 2 r_b - gap [m] (gap > 0: interpenetration)."""
    state = model.initial_state(PRELOAD)
    r_b = model.geometry.ball_radius
    centre = state.ball_position[0]
    radius = math.hypot(centre[0], centre[1])
    target = 2.0 * r_b - gap

    def distance(turn: float) -> float:  # helical motion: same groove offsets
        return math.hypot(2.0 * radius * math.sin(turn / 2.0), model.lead_rate * turn)

    lo, hi = 0.0, 1.0
    for _ in range(200):  # bisection: distance grows with the turn
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if distance(mid) < target else (lo, mid)
    turn = 0.5 * (lo + hi)
    c, s = math.cos(turn), math.sin(turn)
    x, y, z = centre
    state.ball_position[1] = [c * x - s * y, s * x + c * y, z + model.lead_rate * turn]
    state.helix_parameter[1] = state.helix_parameter[0] + turn
    return state


def model(
    sphere_contacts: bool, config: TwinConfig | None = None, time_step: float = 2e-7
) -> DynamicModel:
    return DynamicModel(
        config or frictionless(),
        temperature=293.15,
        time_step=time_step,
        jacobian_interval=5,  # a cost setting: the Newton iterations converge either way
        controller=SpeedController(0.0, 0.0),
        sphere_contacts=sphere_contacts,
    )


def test_pushed_spheres_feel_the_hertz_force_of_two_equal_spheres() -> None:
    gap = 1e-6
    with_pairs, without = model(True), model(False)
    state = neighbours(with_pairs, gap)
    neighbours(without, gap)  # same initial nut offsets
    after_on, report = with_pairs.step(state, Commands(0.0, PRELOAD))
    after_off, _ = without.step(state, Commands(0.0, PRELOAD))
    mass = with_pairs._scene.ball_mass
    impulse = mass * (after_on.ball_velocity - after_off.ball_velocity) / with_pairs.time_step
    line = state.ball_position[1] - state.ball_position[0]
    delta = 2.0 * with_pairs.geometry.ball_radius - float(np.linalg.norm(line))
    line /= np.linalg.norm(line)
    mats = BASE.materials.ball
    e_star = mats.young_modulus / (2.0 * (1.0 - mats.poisson_ratio**2))
    hertz = 4.0 / 3.0 * e_star * math.sqrt(with_pairs.geometry.ball_radius / 2.0) * delta**1.5
    assert report.sphere_pairs is not None and report.sphere_pairs.in_contact[0]
    assert not report.sphere_pairs.in_contact[1]  # the slave nut's spheres stay apart
    assert float(impulse[0] @ line) == pytest.approx(-hertz, rel=1e-6)  # pushed apart
    assert float(impulse[1] @ line) == pytest.approx(hertz, rel=1e-6)
    np.testing.assert_allclose(impulse[2:], 0.0, atol=1e-6 * hertz)


def _free_pair(m: DynamicModel, gap: float, speed: float) -> DynamicState:
    """Master-nut spheres 0 and 1 far outside the grooves (no groove contact), ``gap`` [m]
    apart, sphere 1 flying at sphere 0 at ``speed`` [m/s] along their line of centres."""
    state = m.initial_state(0.0)
    state.ball_position[:, :2] *= 3.0  # radially out of the grooves
    line = np.array([0.6, 0.0, 0.8])
    r_b = m.geometry.ball_radius
    state.ball_position[1] = state.ball_position[0] + (2.0 * r_b + gap) * line
    state.ball_velocity[1] = -speed * line
    return state


def _run(m: DynamicModel, state: DynamicState, steps: int) -> tuple[DynamicState, float, bool]:
    """``steps`` steps; the final state, the energy dissipated [J] (trapezoid) and whether the
    pair touched."""
    dissipated, touched, previous = 0.0, False, 0.0
    for k in range(steps):
        state, report = m.step(state, Commands(0.0, 0.0))
        pairs = report.sphere_pairs
        touched = touched or (pairs is not None and bool(pairs.in_contact[0]))
        if k:
            dissipated += 0.5 * m.time_step * (previous + report.dissipation)
        previous = report.dissipation
    return state, dissipated, touched


def test_collision_of_neighbours_creates_no_energy() -> None:
    """Frictionless and undamped, a head-on impact returns its energy (and momentum); with
    friction, damping and spin, energy is only lost, and the loss is the reported dissipation."""
    m, apart = model(True, time_step=5e-7), model(False, time_step=5e-7)
    state = _free_pair(m, 2e-7, 0.05)
    momentum = state.ball_velocity[:2].sum(axis=0)
    start = sum(m.energy(state).values())
    kinetic = m.energy(state)["kinetic"]
    # The same flight without sphere contacts (they pass through each other) carries the
    # integrator's free-fall energy error m g^2 dt^2 N / 2 per sphere, identical with contacts.
    passed, _, _ = _run(apart, _free_pair(apart, 2e-7, 0.05), STEPS)
    drift = sum(apart.energy(passed).values()) - start
    state, _, touched = _run(m, state, STEPS)
    assert touched
    assert not np.any(m.contact_actions(state).contacts.active)  # free flight throughout
    g = np.array([0.0, 0.0, -BASE.environment.gravity])
    np.testing.assert_allclose(
        state.ball_velocity[:2].sum(axis=0), momentum + 2 * g * STEPS * m.time_step, atol=1e-12
    )
    assert abs(sum(m.energy(state).values()) - start - drift) < 1e-3 * kinetic
    # Sphere 0 leaves with (nearly) all the speed: equal masses exchange their velocities.
    assert float(state.ball_velocity[0] @ np.array([0.6, 0.0, 0.8])) < -0.049

    lossy = model(True, dataclasses.replace(BASE, screw=frictionless().screw), 5e-7)
    state = _free_pair(lossy, 2e-7, 0.05)
    state.ball_omega[1] = [0.0, 300.0, 0.0]  # spinning: the contact slides
    start = sum(lossy.energy(state).values())
    state, dissipated, touched = _run(lossy, state, STEPS)
    end = sum(lossy.energy(state).values())
    assert touched and dissipated > 0.0
    loss = start - (end - drift)
    # Energy only leaves, as the reported dissipation (trapezoid) plus the first-order numerical
    # dissipation of backward Euler: measured 4.2, 2.2, 1.1 % of the loss at 0.5, 0.25, 0.125 us.
    assert 0.0 < dissipated <= loss
    assert dissipated == pytest.approx(loss, rel=0.06)
