"""Dynamic model: short-horizon checks against independent oracles (issue 4's CI tests).

Free flight against the closed-form solution of the integrator, a preloaded static state
against exact Hertz and the axial balance, energy conservation with friction and damping off,
the order of convergence in the time step, and finite states at the envelope corners.
"""

import dataclasses
import math
import re

import numpy as np
import pytest
from physics.hertz_oracle import exact_hertz  # test/ is on sys.path (pytest prepend mode)

from ballscrew_twin.errors import OperatingPointError
from ballscrew_twin.models.dynamic import DynamicModel
from ballscrew_twin.models.dynamic_state import Commands, SpeedController
from ballscrew_twin.params import TwinConfig, load_config

BASE = load_config()


def small(config: TwinConfig, balls: int = 2, **contact: float) -> TwinConfig:
    """Few spheres per nut (fast), optionally other contact-law values."""
    screw = dataclasses.replace(config.screw, balls_per_nut=balls)
    return dataclasses.replace(
        config, screw=screw, contact=dataclasses.replace(config.contact, **contact)
    )


def frictionless(balls: int = 2) -> TwinConfig:
    """No friction of any kind, no damping, negligible viscous rolling resistance."""
    config = small(BASE, balls, dry_friction_coefficient=0.0, damping_coefficient=0.0)
    lub = dataclasses.replace(
        config.lubricant,
        limiting_shear_stress=0.0,
        limiting_shear_pressure_coefficient=0.0,
        viscosity_reference=1e-5,
        viscosity_second=5e-6,
    )
    return dataclasses.replace(config, lubricant=lub)


def test_free_flight_sphere_follows_the_integrator_exactly() -> None:
    model = DynamicModel(small(BASE, 1), temperature=293.15, time_step=1e-6)
    state = model.initial_state(0.0)
    state.ball_position[0] *= 3.0  # far outside the grooves: no contact
    state.ball_omega[0] = [10.0, -20.0, 30.0]
    start = state.ball_position[0].copy()
    steps = 200
    for _ in range(steps):
        state, report = model.step(state, Commands(0.0, 0.0))
        assert not report.contacts.active[0].any()
    g = model.config.environment.gravity
    dt = model.time_step
    np.testing.assert_allclose(state.ball_velocity[0], [0.0, 0.0, -g * steps * dt], atol=1e-15)
    drop = -g * dt**2 * steps * (steps + 1) / 2  # semi-implicit Euler, exactly
    np.testing.assert_allclose(state.ball_position[0] - start, [0.0, 0.0, drop], atol=1e-15)
    np.testing.assert_allclose(state.ball_omega[0], [10.0, -20.0, 30.0], rtol=1e-14)


def test_preloaded_static_state_stays_and_matches_hertz() -> None:
    preload = 400.0
    model = DynamicModel(small(BASE, 2), temperature=293.15, time_step=1e-6)
    state = model.initial_state(preload)
    for _ in range(300):
        state, report = model.step(state, Commands(0.0, preload))
    # (The nuts' weight back-drives the screw until the PI integral holds it: the spheres
    # creep meanwhile, so their speed is not zero; the forces are what is checked.)
    weight = BASE.screw.nut_mass * BASE.environment.gravity
    # Axial balance of each nut: the spheres carry the preload less/plus the nut weight.
    np.testing.assert_allclose(report.nut_force, [-(preload - weight), preload + weight], rtol=2e-3)
    ev = report.contacts
    geom = model.geometry
    e_star = model._scene.e_star
    for i, j in zip(*np.nonzero(ev.active), strict=True):
        force = float(ev.hertz.stiffness[i, j] * ev.approach[i, j] ** 1.5)
        alpha = float(ev.contact_angle[i, j])
        sign = 1.0 if j >= 2 else -1.0  # nut: concave along the rolling direction
        radius = geom.pitch_radius + sign * geom.ball_radius * math.cos(alpha)
        k_roll = -sign * math.cos(alpha) * math.cos(geom.helix_angle) ** 2 / radius
        r_x = 1 / (1 / geom.ball_radius + k_roll)
        r_y = 1 / (1 / geom.ball_radius - 1 / geom.groove_radius)
        exact = exact_hertz(force, r_x, r_y, e_star)
        assert ev.approach[i, j] == pytest.approx(exact.approach, rel=1e-4)


def test_elastic_energy_from_contacts_evaluated_at_other_velocities() -> None:
    """energy(state, contacts): approach, contact set and stiffness depend on the positions
    only, so contacts evaluated at the same positions but other velocities (as the compiled
    loop's first step of a stretch) give energy(state)'s own elastic energy."""
    preload = 400.0
    model = DynamicModel(small(BASE, 2), temperature=293.15, time_step=1e-6)
    state = model.initial_state(preload)
    for _ in range(50):
        state, _ = model.step(state, Commands(5.0, preload))
    own = model.energy(state)
    moved = model.contact_actions(
        state,
        state.ball_velocity + 0.01,
        state.ball_omega * 2.0,
        state.nut_velocity + 1e-3,
        state.screw_speed + 1.0,
    ).contacts
    assert own["elastic"] > 0.0
    assert model.energy(state, moved) == pytest.approx(own, rel=1e-14, abs=0.0)


def _total_energy(model: DynamicModel, state, preload: float) -> float:  # type: ignore[no-untyped-def]
    terms = model.energy(state)
    separation = state.nut_position[0] - state.nut_position[1]
    return sum(terms.values()) - preload * separation  # the preload's potential


def _undriven(dt: float, balls: int = 2, implicit: bool = False) -> DynamicModel:
    """The frictionless screw of ``balls`` spheres per nut at 20 C, stepped at ``dt`` [s] with
    a Jacobian kept all run, no speed control, sphere positions implicit or not."""
    return DynamicModel(
        frictionless(balls),
        temperature=293.15,
        time_step=dt,
        jacobian_interval=10**9,
        controller=SpeedController(0.0, 0.0),
        implicit_positions=implicit,
    )


def _energy_errors(dt: float, duration: float) -> tuple[float, float, float]:
    """Largest |E(t) - E(0)| over the first and the last quarter of the run, and KE(0) [J]."""
    preload = 300.0
    model = _undriven(dt)
    state = model.initial_state(preload)
    rng = np.random.default_rng(3)
    state.ball_velocity += rng.normal(0.0, 0.02, state.ball_velocity.shape)
    start = _total_energy(model, state, preload)
    kinetic = model.energy(state)["kinetic"]
    steps = round(duration / dt)
    errors = []
    for _ in range(steps):
        state, _ = model.step(state, Commands(0.0, preload))
        errors.append(abs(_total_energy(model, state, preload) - start))
    quarter = steps // 4
    return max(errors[:quarter]), max(errors[-quarter:]), kinetic


def test_energy_is_conserved_without_friction_and_damping() -> None:
    """Energy error bounded in time and not growing as the step shrinks.

    Measured (0.5 ms, KE(0) = 7.2e-7 J of random sphere velocities): max |E - E(0)| =
    6.4e-8, 4.0e-8, 3.0e-8, 2.6e-8 J at dt = 5e-7, 2.5e-7, 1.25e-7, 6.25e-8 s: an integrator
    part that shrinks with dt over a floor of ~3e-8 J (4 % of KE(0)) from the model itself
    (docs/model.md section 10: normal force along the helicoid normal, approach from the
    normal-plane geometry).
    """
    first, last, kinetic = _energy_errors(5e-7, 1e-3)
    first_fine, last_fine, _ = _energy_errors(2.5e-7, 1e-3)
    assert max(first, last) < 0.25 * kinetic  # bounded: dt omega ~ 0.4 at 5e-7 s
    assert last < 1.5 * first  # no secular drift over 2000 steps
    assert max(first_fine, last_fine) < max(first, last)  # smaller with the smaller step


def _nut_position_after(dt: float, horizon: float, implicit: bool = False) -> float:
    """The two nuts' separation [m] after a smooth preload ramp of ``horizon`` [s] in steps
    of ``dt`` [s], with implicit sphere positions or not."""
    model = _undriven(dt, balls=1, implicit=implicit)
    state = model.initial_state(200.0)
    for _ in range(round(horizon / dt)):
        x = min(state.time / horizon, 1.0)
        state, _ = model.step(state, Commands(0.0, 200.0 + 100.0 * (3 * x * x - 2 * x**3)))
    return float(state.nut_position[0] - state.nut_position[1])


def test_convergence_in_the_time_step() -> None:
    """Semi-implicit Euler converges at least at first order; on this smooth, slowly driven
    case (preload ramped over many contact periods) the measured order is 2.0."""
    horizon = 2e-4
    reference = _nut_position_after(2.5e-8, horizon)
    errors = [abs(_nut_position_after(dt, horizon) - reference) for dt in (4e-7, 2e-7, 1e-7)]
    orders = [math.log2(errors[k] / errors[k + 1]) for k in range(2)]
    assert all(p > 0.9 for p in orders), (errors, orders)


@pytest.mark.parametrize("preload", [0.0, 3000.0])
@pytest.mark.parametrize("rpm", [100.0, 4000.0])
@pytest.mark.parametrize("celsius", [-20.0, 60.0])
def test_envelope_corners_stay_finite(preload: float, rpm: float, celsius: float) -> None:
    model = DynamicModel(small(BASE, 2), temperature=celsius + 273.15, time_step=1e-6)
    state = model.initial_state(preload)
    target = rpm * 2 * math.pi / 60
    for _ in range(300):
        x = min(state.time / 2e-4, 1.0)
        state, report = model.step(state, Commands(target * (3 * x * x - 2 * x**3), preload))
    ev = report.contacts
    for array in (
        state.ball_position,
        state.ball_velocity,
        state.ball_omega,
        ev.film_total,
        ev.hertz.stiffness,
    ):
        assert np.all(np.isfinite(array))
    assert np.all(ev.film_total >= 0.0)
    assert np.isfinite(report.motor_torque) and np.isfinite(state.screw_speed)


def _energy_drift(dt: float, implicit: bool, duration: float = 1e-3) -> tuple[float, float]:
    """Largest E(t) - E(0) [J] (inf once a value is not finite) of the frictionless preloaded
    spheres with random velocities, and KE(0) [J]."""
    preload = 300.0
    model = _undriven(dt, implicit=implicit)
    state = model.initial_state(preload)
    rng = np.random.default_rng(3)
    state.ball_velocity += rng.normal(0.0, 0.02, state.ball_velocity.shape)
    start = _total_energy(model, state, preload)
    kinetic = model.energy(state)["kinetic"]
    worst = -math.inf
    for _ in range(round(duration / dt)):
        state, _ = model.step(state, Commands(0.0, preload))
        change = _total_energy(model, state, preload) - start
        if not math.isfinite(change):
            return math.inf, kinetic
        worst = max(worst, change)
    return worst, kinetic


def test_implicit_positions_are_stable_beyond_the_explicit_limit() -> None:
    """At 4 us, beyond the semi-implicit step's limit 2 / omega (~3 us for a sphere between
    its contacts, docs/model.md section 10), the contact springs blow the semi-implicit step up
    (measured: energy grows by 1e73 J within 1 ms), while with the sphere positions implicit
    (backward Euler) the frictionless, undamped system only loses energy (numerical
    dissipation; measured: E - E(0) <= -0.24 KE(0) from the first step on)."""
    explicit, kinetic = _energy_drift(4e-6, implicit=False)
    implicit, _ = _energy_drift(4e-6, implicit=True)
    assert explicit > 100.0 * kinetic  # the case is beyond the explicit limit
    assert implicit <= 0.0, (implicit, kinetic)


def test_implicit_positions_converge_to_the_semi_implicit_solution() -> None:
    """With implicit sphere positions the steps of 4, 2 and 1 us, all beyond or at the
    semi-implicit limit, converge to the semi-implicit solution at 0.025 us (an independent
    integration of the same equations) at least at first order (measured: errors 3.1e-10,
    7.1e-11, 1.5e-11 m of 3.9e-6 m, order 2.1 and 2.3)."""
    horizon = 2e-4
    reference = _nut_position_after(2.5e-8, horizon, implicit=False)
    errors = [
        abs(_nut_position_after(dt, horizon, implicit=True) - reference)
        for dt in (4e-6, 2e-6, 1e-6)
    ]
    orders = [math.log2(errors[k] / errors[k + 1]) for k in range(2)]
    assert all(p > 0.9 for p in orders), (errors, orders)
    assert errors[0] < 1e-3 * abs(reference), (errors, reference)


@pytest.mark.parametrize(
    ("setting", "message"),
    [
        ({"time_step": 0.0}, "time_step = 0.0 is outside the allowed range (0, 0.0001] s"),
        ({"time_step": 2e-4}, "time_step = 0.0002 is outside the allowed range (0, 0.0001] s"),
        ({"time_step": math.nan}, "time_step: nan is not a finite number"),
        ({"jacobian_interval": 0}, "jacobian_interval = 0 is outside the allowed range [1, inf] -"),
        ({"jacobian_interval": 1.5}, "jacobian_interval: expected a whole number, got 1.5"),
    ],
)
def test_an_integrator_setting_out_of_range_is_refused_naming_it(
    setting: dict[str, float], message: str
) -> None:
    with pytest.raises(OperatingPointError) as err:
        DynamicModel(small(BASE), 293.15, backend="reference", **setting)  # type: ignore[arg-type]
    assert message in str(err.value)


def test_a_step_change_out_of_range_is_refused_and_the_step_kept() -> None:
    model = DynamicModel(small(BASE), 293.15, time_step=1e-6, backend="reference")
    with pytest.raises(OperatingPointError, match=re.escape("time_step = -1e-06 is outside")):
        model.set_integrator(-1e-6, implicit_positions=True)
    assert model.time_step == 1e-6 and not model.implicit_positions
    model.set_integrator(1e-4, implicit_positions=True)  # the closed end
    assert model.time_step == 1e-4 and model.implicit_positions
