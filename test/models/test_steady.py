"""Steady-state model: equilibrium, power balance and limiting cases.

Oracles: Hertz load sharing of a statically preloaded nut (axial force / (Z sin a cos l)), the
work-energy theorem (the moment the spheres put on the screw, less the torque of lifting the
nuts, equals the dissipated power over the speed), and the equivalence of the symmetric and the
full (every sphere) solutions on a vertical screw.
"""

import math

import numpy as np
import pytest

from ballscrew_twin.errors import SolverError
from ballscrew_twin.models.base import OperatingPoint
from ballscrew_twin.models.catalog import CatalogModel
from ballscrew_twin.models.steady import SteadyStateModel
from ballscrew_twin.params import load_config

RPM = 2 * math.pi / 60


@pytest.fixture(scope="module")
def config():  # type: ignore[no-untyped-def]
    return load_config()


def op(rpm: float, celsius: float, preload: float) -> OperatingPoint:
    return OperatingPoint(screw_speed=rpm * RPM, temperature=celsius + 273.15, preload=preload)


def test_static_preload_is_shared_by_hertz_contacts(config) -> None:  # type: ignore[no-untyped-def]
    sol = SteadyStateModel(config).solve(op(0.0, 20.0, 1500.0))
    cs = sol.output.contacts
    assert cs is not None
    loaded = cs.in_contact
    assert loaded.sum() == 4  # one screw and one nut contact per nut
    weight = config.screw.nut_mass * config.environment.gravity
    for nut, axial in ((0, 1500.0 - weight), (1, 1500.0 + weight)):
        rows = loaded & (cs.nut == nut)
        alpha = cs.contact_angle[rows]
        expected = axial / (
            config.screw.balls_per_nut * np.sin(alpha) * math.cos(config.screw.helix_angle)
        )
        # Sphere weight and the helix-normal tilt make the last 0.3 %.
        np.testing.assert_allclose(cs.normal_force[rows], expected, rtol=3e-3)
    # Preload pushes the contact angle above its free value (paper Fig. 10b).
    assert np.all(cs.contact_angle[loaded] > config.screw.free_contact_angle)
    assert sol.output.drag_torque == 0.0


@pytest.mark.parametrize(
    ("rpm", "celsius", "preload"), [(100, 20, 500), (100, 60, 3000), (1000, 20, 1500)]
)
def test_power_balance_closes(config, rpm: float, celsius: float, preload: float) -> None:  # type: ignore[no-untyped-def]
    sol = SteadyStateModel(config).solve(op(rpm, celsius, preload))
    drag = sol.output.drag_torque
    assert drag > 0.0
    assert sol.screw_torque_direct - sol.gravity_torque == pytest.approx(drag, rel=1e-7)
    # Every mechanism dissipates, none generates.
    for name in (
        "lubricant_shear",
        "dry_contact",
        "rolling_resistance",
        "hysteresis",
        "curvature",
        "spin",
    ):
        assert getattr(sol.output.breakdown, name) >= 0.0, name
    assert sum(sol.output.nut_torque) == pytest.approx(drag, rel=1e-9)


def test_symmetric_and_full_modes_agree_on_a_vertical_screw(config) -> None:  # type: ignore[no-untyped-def]
    point = op(100, 20, 1500)
    sym = SteadyStateModel(config, mode="symmetric").solve(point)
    full = SteadyStateModel(config, mode="full").solve(point)
    assert len(full.balls.nut) == 2 * config.screw.balls_per_nut
    assert full.output.drag_torque == pytest.approx(sym.output.drag_torque, rel=1e-6)
    assert "symmetric" in sym.output.notes[0]


def test_reversed_speed_reverses_torque(config) -> None:  # type: ignore[no-untyped-def]
    fwd = SteadyStateModel(config).evaluate(op(100, 20, 1000))
    rev = SteadyStateModel(config).evaluate(op(-100, 20, 1000))
    assert rev.drag_torque == pytest.approx(-fwd.drag_torque, rel=0.05)


def test_drag_rises_with_preload_and_regimes_follow_temperature(config) -> None:  # type: ignore[no-untyped-def]
    model = SteadyStateModel(config)
    drags = [model.evaluate(op(100, 20, f)).drag_torque for f in (500, 1500, 3000)]
    assert drags[0] < drags[1] < drags[2]
    tallian = {}
    for celsius in (-20, 20, 60):
        cs = model.evaluate(op(100, celsius, 1500)).contacts
        assert cs is not None
        tallian[celsius] = cs.tallian_parameter[cs.in_contact].mean()
    # Paper section 3: -20 C full film (Lambda > 3), 20 C mixed, 60 C near boundary.
    assert tallian[-20] > 3.0
    assert 0.5 < tallian[20] < 3.0
    assert tallian[60] < tallian[20]


def test_zero_preload_has_a_defined_answer(config) -> None:  # type: ignore[no-untyped-def]
    out = SteadyStateModel(config).evaluate(op(100, 20, 0.0))
    assert math.isfinite(out.drag_torque) and out.drag_torque >= 0.0
    cs = out.contacts
    assert cs is not None
    # Only the nut weights load the spheres: both nuts bear on the S1/N2 flanks.
    assert set(cs.half_groove[cs.in_contact].tolist()) == {0, 3}


def test_warm_start_is_cheaper_than_cold(config) -> None:  # type: ignore[no-untyped-def]
    # A step of the start-up path (same temperature and loads, higher speed) is solved warm by
    # every model; another load is solved warm by a model that follows its path.
    model = SteadyStateModel(config)
    cold = model.solve(op(100, 20, 1500))
    assert model.solve(op(102, 20, 1500)).iterations < cold.iterations
    path = SteadyStateModel(config, branch="path")
    cold = path.solve(op(100, 20, 1500))
    assert path.solve(op(100, 20, 1520)).iterations < cold.iterations


def test_catalogue_is_an_order_of_magnitude_reference(config) -> None:  # type: ignore[no-untyped-def]
    """Uncalibrated defaults: the steady drag is within a factor 10 of Eq. 52 (see docs)."""
    steady = SteadyStateModel(config).evaluate(op(100, 20, 3000)).drag_torque
    zhou = CatalogModel(config).torque_at_preload(3000)
    assert zhou / 10 < steady < zhou * 10


@pytest.mark.parametrize("mode", ["symmetric", "full"])
def test_compiled_and_reference_backends_agree(config, mode: str) -> None:  # type: ignore[no-untyped-def]
    point = op(1000, -20, 800)
    ref = SteadyStateModel(config, mode=mode, backend="reference").solve(point)  # type: ignore[arg-type]
    fast = SteadyStateModel(config, mode=mode, backend="compiled").solve(point)  # type: ignore[arg-type]
    assert fast.output.drag_torque == pytest.approx(ref.output.drag_torque, rel=1e-8)
    np.testing.assert_allclose(fast.state.kinematics, ref.state.kinematics, rtol=1e-7)


def test_external_load_goes_to_the_master_nut(config) -> None:  # type: ignore[no-untyped-def]
    """Force preload (paper): an external load on the master nut changes only its spheres."""
    model = SteadyStateModel(config)
    base = model.solve(op(100, 20, 1000)).output.contacts
    push = OperatingPoint(
        screw_speed=100 * RPM, temperature=293.15, preload=1000.0, axial_load=500.0
    )
    loaded = model.solve(push).output.contacts
    assert base is not None and loaded is not None
    for nut, ratio in ((0, 1500.0 / 1000.0), (1, 1.0)):
        before = base.normal_force[base.in_contact & (base.nut == nut)].mean()
        after = loaded.normal_force[loaded.in_contact & (loaded.nut == nut)].mean()
        assert after / before == pytest.approx(ratio, rel=0.02)


def test_master_nut_unloads_onto_the_other_flanks(config) -> None:  # type: ignore[no-untyped-def]
    pull = OperatingPoint(
        screw_speed=100 * RPM, temperature=293.15, preload=300.0, axial_load=-800.0
    )
    cs = SteadyStateModel(config).solve(pull).output.contacts
    assert cs is not None
    master = set(cs.half_groove[cs.in_contact & (cs.nut == 0)].tolist())
    assert master == {0, 3}  # S1/N2 instead of S2/N1: the nut is pushed the other way


def test_horizontal_screw_solves_every_sphere(config) -> None:  # type: ignore[no-untyped-def]
    import dataclasses

    horizontal = dataclasses.replace(
        config, screw=dataclasses.replace(config.screw, orientation="horizontal")
    )
    model = SteadyStateModel(horizontal)
    assert model.resolved_mode() == "full"
    sol = model.solve(op(100, 20, 1500))
    cs = sol.output.contacts
    assert cs is not None
    forces = cs.normal_force[cs.in_contact & (cs.nut == 0)]
    assert len(forces) == 2 * config.screw.balls_per_nut
    # Gravity on each sphere varies with its azimuth: loads differ, but only by ~m g / Q.
    assert forces.std() > 0.0
    assert forces.std() / forces.mean() < 1e-3
    assert sol.screw_torque_direct - sol.gravity_torque == pytest.approx(
        sol.output.drag_torque, rel=1e-7
    )


def test_inertial_actions_are_the_terms_the_steady_contact_laws_add(config) -> None:  # type: ignore[no-untyped-def]
    """Oracle: steady-form minus dynamic-form evaluation of the same states, and the closed
    forms m (Omega + w_B)^2 d_axis (centrifugal) and |gyro| <= (Omega + w_B) I |omega_abs|."""
    from ballscrew_twin.models.contact_forces import evaluate_contacts, make_scene
    from ballscrew_twin.models.steady import inertial_actions
    from ballscrew_twin.physics import geometry

    model = SteadyStateModel(config, mode="full")
    sol = model.solve(op(3000, 20, 500))
    state, balls = sol.state, sol.balls
    scene = make_scene(config, 293.15, 3000 * RPM)
    e_ball = state.nut_offset[balls.nut]
    steady = evaluate_contacts(scene, state.ball_nb, state.kinematics, e_ball, balls.gravity)
    geom = scene.geometry
    zhat = geometry.axis_direction(geom.helix_angle)
    r_ball = np.stack(
        [np.zeros(len(balls.nut)), state.ball_nb[:, 0] - geom.pitch_radius, state.ball_nb[:, 1]],
        axis=-1,
    )
    lead_rate = geom.lead / (2 * math.pi)
    velocity = state.kinematics[:, :1] * (np.cross(zhat, r_ball) + lead_rate * zhat)
    dynamic = evaluate_contacts(
        scene, state.ball_nb, state.kinematics, e_ball, balls.gravity, centre_velocity=velocity
    )
    centrifugal, gyroscopic = inertial_actions(scene, state.ball_nb, state.kinematics)
    expected = steady.force - dynamic.force - scene.ball_mass * balls.gravity
    scale = np.abs(steady.force).max() + np.abs(dynamic.force).max()
    assert np.abs(centrifugal - expected).max() < 1e-9 * scale
    assert (
        np.abs(gyroscopic - (dynamic.moment - steady.moment)).max()
        < 1e-9 * np.abs(dynamic.moment).max()
    )
    orbit = 3000 * RPM + state.kinematics[:, 0]
    distance = np.linalg.norm(np.cross(r_ball, zhat), axis=1)
    assert np.linalg.norm(centrifugal, axis=1) == pytest.approx(
        scene.ball_mass * orbit**2 * distance, rel=1e-12
    )


def test_dropping_inertial_terms_matters_only_at_speed(config) -> None:  # type: ignore[no-untyped-def]
    full = SteadyStateModel(config)
    reduced = SteadyStateModel(config, inertial_terms=False)
    # Standstill: no orbit, nothing to drop (exactly the same equations).
    assert reduced.solve(op(0, 20, 1500)).state.ball_nb == pytest.approx(
        full.solve(op(0, 20, 1500)).state.ball_nb, abs=0.0
    )
    # Centrifugal force ~ Omega^2: negligible at 10 rpm, not at 4000 rpm without preload.
    slow = full.evaluate(op(10, 20, 1500)).drag_torque
    assert reduced.evaluate(op(10, 20, 1500)).drag_torque == pytest.approx(slow, rel=1e-4)
    fast = full.evaluate(op(4000, 20, 0)).drag_torque
    dropped = reduced.evaluate(op(4000, 20, 0))
    assert abs(dropped.drag_torque - fast) > 0.01 * abs(fast)
    assert dropped.fidelity == "steady-no-inertia-symmetric"
    assert any("dropped" in note for note in dropped.notes)


def test_lubricant_state_is_computed_once_per_temperature(config) -> None:  # type: ignore[no-untyped-def]
    from dataclasses import fields

    from ballscrew_twin.models.contact_forces import make_scene

    model = SteadyStateModel(config, branch="path")  # one warm solve at the second point
    model.solve(op(100, 20, 1500))
    hits = model.scene_cache_hits
    model.solve(op(200, 20, 1000))
    assert model.scene_cache_hits == hits + 1
    for speed in (0.0, 3.0):
        cached, fresh = model.scene(293.15, speed), make_scene(config, 293.15, speed)
        for f in fields(fresh):
            assert getattr(cached, f.name) == getattr(fresh, f.name), f.name


def test_a_model_cache_drops_its_oldest_entry_at_its_size() -> None:
    from ballscrew_twin.models.steady_types import SCENE_CACHE_SIZE, kept

    cache: dict[int, str] = {}
    for k in range(SCENE_CACHE_SIZE):
        assert kept(cache, k, str(k)) == str(k)
    assert kept(cache, 0, "again") == "again"  # a key it holds: replaced, nothing dropped
    assert len(cache) == SCENE_CACHE_SIZE and cache[0] == "again"
    kept(cache, SCENE_CACHE_SIZE, "new")  # full: the oldest inserted (0) goes
    assert 0 not in cache and 1 in cache and len(cache) == SCENE_CACHE_SIZE


def test_auto_mode_falls_back_to_every_sphere_where_the_reduction_stalls(config) -> None:  # type: ignore[no-untyped-def]
    # Since the smoothed film laws (D16) no point of the envelope is known where the one-sphere
    # reduction stalls (2 N, 3900 rpm, 20 C was one): the stall is imposed here.
    op = OperatingPoint(screw_speed=3900 * RPM, temperature=293.15, preload=2.0)
    model = SteadyStateModel(config, mode="auto")
    solve_in_mode = model._solve_in_mode

    def stalling(point, mode, warm_start):  # type: ignore[no-untyped-def]
        if mode == "symmetric":
            raise SolverError("steady state did not converge in 80 iterations (imposed)")
        return solve_in_mode(point, mode, warm_start)

    model._solve_in_mode = stalling  # type: ignore[method-assign]
    out = model.evaluate(op)
    full = SteadyStateModel(config, mode="full").evaluate(op)
    assert out.fidelity == "steady-full"
    assert any("full mode" in note for note in out.notes)
    assert out.drag_torque == pytest.approx(full.drag_torque, rel=1e-6)
