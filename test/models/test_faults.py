"""Defects: approach offsets of a defective sphere and a spall, and their effect in the model."""

import dataclasses
import math

import numpy as np
import pytest

from ballscrew_twin.errors import ConfigError
from ballscrew_twin.kernels.contacts import evaluate_contacts_compiled
from ballscrew_twin.models.base import OperatingPoint
from ballscrew_twin.models.contact_forces import evaluate_contacts, make_scene
from ballscrew_twin.models.dynamic import DynamicModel
from ballscrew_twin.models.dynamic_state import Commands
from ballscrew_twin.models.faults import (
    Faults,
    RacewaySpall,
    SphereDefect,
    SphereJam,
    faults_from_mapping,
)
from ballscrew_twin.models.steady import SteadyStateModel
from ballscrew_twin.params import load_config

BASE = load_config()


def test_spall_profile_and_frames() -> None:
    spall = RacewaySpall(half_groove="S2", centre=1.0, width=0.2, depth=10e-6)
    nut_spall = RacewaySpall(half_groove="N1", centre=1.0, width=0.2, depth=10e-6)
    faults = Faults(spalls=(spall, nut_spall))
    theta = np.array([1.0, 1.05, 1.1, 1.5])
    nut = np.zeros(4, dtype=np.int64)
    offsets = faults.approach_offsets(theta, 0.0, nut, np.arange(4))
    assert offsets is not None
    np.testing.assert_allclose(offsets[:, 1], [-10e-6, -5e-6, 0.0, 0.0], atol=1e-18)
    np.testing.assert_allclose(offsets[:, 2], offsets[:, 1])  # nut at phi = 0: same place
    # The nut turns with -phi relative to the screw: its spall meets the sphere at theta - phi.
    moved = faults.approach_offsets(theta - 0.5, 0.5, nut, np.arange(4))
    assert moved is not None
    np.testing.assert_allclose(moved[:, 2], offsets[:, 2], atol=1e-18)
    # The screw's spall stays at screw parameter 1.0 whatever phi: the 4th sphere is now on it.
    np.testing.assert_allclose(moved[:, 1], [0.0, 0.0, 0.0, -10e-6], atol=1e-18)
    assert Faults().approach_offsets(theta, 0.0, nut, np.arange(4)) is None


def test_defective_sphere_offsets_only_itself() -> None:
    faults = Faults(spheres=(SphereDefect(nut=1, index=2, radius_change=3e-6),))
    nut = np.repeat(np.array([0, 1]), 3)
    offsets = faults.approach_offsets(np.zeros(6), 0.0, nut, np.tile(np.arange(3), 2))
    assert offsets is not None
    expected = np.zeros((6, 4))
    expected[5] = 3e-6
    np.testing.assert_array_equal(offsets, expected)


@pytest.mark.parametrize(
    ("data", "word"),
    [
        ({"spheres": [{"nut": 2, "index": 0, "radius_change": 1e-6}]}, "spheres[0].nut"),
        ({"spheres": [{"nut": 0, "index": 9, "radius_change": 1e-6}]}, "spheres[0].index"),
        ({"spheres": [{"nut": 0, "index": 0, "radius_change": 1e-3}]}, "radius_change"),
        (
            {"spalls": [{"half_groove": "X1", "centre": 0, "width": 0.1, "depth": 1e-6}]},
            "half_groove",
        ),
        (
            {"spalls": [{"half_groove": "S1", "centre": 0, "width": 0.1, "depth": float("nan")}]},
            "depth",
        ),
        ({"cracks": []}, "unknown"),
    ],
)
def test_bad_faults_are_rejected_naming_the_field(
    data: dict,  # type: ignore[type-arg]
    word: str,
) -> None:
    with pytest.raises(ConfigError, match=r"scene\.yaml") as err:
        faults_from_mapping(data, 3, "scene.yaml: faults")
    assert word in str(err.value)


def test_kernel_matches_reference_with_offsets() -> None:
    point = OperatingPoint(screw_speed=30.0, temperature=293.15, preload=800.0)
    sol = SteadyStateModel(BASE, mode="full").solve(point)
    scene = make_scene(BASE, point.temperature, point.screw_speed)
    rng = np.random.default_rng(11)
    offsets = rng.normal(0.0, 2e-6, (len(sol.balls.nut), 4))
    args = (
        scene,
        sol.state.ball_nb,
        sol.state.kinematics,
        sol.state.nut_offset[sol.balls.nut],
        sol.balls.gravity,
    )
    ref = evaluate_contacts(*args, approach_offset=offsets)
    fast = evaluate_contacts_compiled(*args, approach_offset=offsets)
    np.testing.assert_array_equal(fast.active, ref.active)
    for name in ("force", "moment", "groove_force", "slip"):
        a, b = getattr(fast, name), getattr(ref, name)
        np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-11 * np.max(np.abs(b)), err_msg=name)
    plain = evaluate_contacts(*args)
    assert not np.allclose(plain.groove_force, ref.groove_force)


def _settled_contacts(faults: Faults) -> tuple[np.ndarray, np.ndarray]:
    config = dataclasses.replace(BASE, screw=dataclasses.replace(BASE.screw, balls_per_nut=3))
    model = DynamicModel(config, temperature=293.15, time_step=1e-6, faults=faults)
    state = model.initial_state(300.0)
    for _ in range(400):
        state, report = model.step(state, Commands(0.0, 300.0))
    ev = report.contacts
    forces = np.where(ev.active, ev.hertz.stiffness * np.maximum(ev.approach, 0.0) ** 1.5, 0.0)
    return forces, report.nut_force


def test_oversized_sphere_and_spall_change_the_load_sharing() -> None:
    healthy, healthy_nuts = _settled_contacts(Faults())
    big, big_nuts = _settled_contacts(
        Faults(spheres=(SphereDefect(nut=0, index=1, radius_change=2e-6),))
    )
    # Master nut spheres bear on S2 (column 1) and N1 (column 2).
    assert big[1, 1] > 1.2 * healthy[1, 1]
    assert big[0, 1] < healthy[0, 1] and big[2, 1] < healthy[2, 1]
    np.testing.assert_allclose(big_nuts, healthy_nuts, rtol=0.02)  # the nut still carries it
    # A spall under sphere 0 of the master nut on the screw flank S2 (helix parameter 0 there).
    hollow, _ = _settled_contacts(
        Faults(spalls=(RacewaySpall(half_groove="S2", centre=0.0, width=0.3, depth=2e-6),))
    )
    assert hollow[0, 1] < 0.8 * healthy[0, 1]
    assert math.isfinite(float(hollow.sum()))


def test_scenario_carries_faults_into_the_simulation(tmp_path) -> None:  # type: ignore[no-untyped-def]
    import yaml

    from ballscrew_twin.models.scenario import load_scenario
    from ballscrew_twin.models.simulation import simulate

    scene = {
        "name": "defect",
        "balls_per_nut": 1,
        "temperature": 293.15,
        "preload": 100.0,
        "preload_ramp_end": 1e-4,
        "speed": 10.0,
        "speed_ramp_start": 1e-4,
        "speed_ramp_end": 2e-4,
        "duration": 4e-4,
        "average_window": 1e-4,
        "time_step": 1e-6,
        "output_interval": 1e-5,
        "contact_output_interval": 1e-4,
        "faults": {"spheres": [{"nut": 1, "index": 0, "radius_change": 1e-6}]},
    }
    path = tmp_path / "defect.yaml"
    path.write_text(yaml.safe_dump(scene))
    healthy = simulate(load_scenario(path).__class__(**{**scene, "faults": None}))
    defective = simulate(load_scenario(path))
    # At the start only the nut weights load the spheres: the oversized slave sphere (1 um)
    # interferes more with its flanks, 24 N instead of 3.8 N (measured). Later samples are
    # dominated by the preload transient of this one-sphere scene.
    assert defective.normal_force[0, 1].max() > 2.0 * healthy.normal_force[0, 1].max()
    scene["faults"] = {"spheres": [{"nut": 0, "index": 3, "radius_change": 1e-6}]}
    path.write_text(yaml.safe_dump(scene))
    with pytest.raises(ConfigError, match="index"):
        simulate(load_scenario(path))  # 1 sphere per nut: index 3 does not exist


def _jam_run(faults: Faults) -> tuple[DynamicModel, object, object]:
    config = dataclasses.replace(BASE, screw=dataclasses.replace(BASE.screw, balls_per_nut=2))
    model = DynamicModel(config, temperature=293.15, time_step=1e-6, faults=faults)
    state = model.initial_state(400.0)
    for k in range(400):
        ramp = min(k / 150.0, 1.0)
        state, report = model.step(state, Commands(30.0 * ramp * ramp * (3 - 2 * ramp), 400.0))
        if faults.jams:
            assert np.all(state.ball_omega[1] == 0.0)  # blocked from the start
    return model, state, report


def test_jammed_sphere_slides_instead_of_rolling() -> None:
    """A sphere whose rotation is blocked cannot roll: its contact points move with its centre,
    so between its screw and nut contacts it slips by the full relative speed of the two
    surfaces, |Omega (r_m - r_b cos alpha) e_theta - v_nut z| (kinematics; it is carried by the
    translating nut and slides on the screw). The rolling spheres slip by a tiny fraction of
    that, and the jam costs power."""
    _, healthy_state, healthy = _jam_run(Faults())
    model, state, report = _jam_run(Faults(jams=(SphereJam(nut=0, index=1, start=0.0),)))
    ev = report.contacts  # type: ignore[attr-defined]
    assert ev.active[1, 1] and ev.active[1, 2]  # master-nut sphere on S2 and N1
    geom = model.geometry
    rho = geom.pitch_radius - geom.ball_radius * math.cos(float(ev.contact_angle[1, 1]))
    surfaces = math.hypot(state.screw_speed * rho, float(state.nut_velocity[0]))  # type: ignore[attr-defined]
    assert float(ev.slip[1, 1] + ev.slip[1, 2]) == pytest.approx(surfaces, rel=0.03)
    assert float(ev.slip[0, 1] + ev.slip[0, 2]) < 0.01 * surfaces  # sphere 0 rolls
    assert report.dissipation > 1.5 * healthy.dissipation  # type: ignore[attr-defined]
    assert np.abs(healthy_state.ball_omega[1]).max() > 1.0  # type: ignore[attr-defined]


def test_jams_are_read_and_validated() -> None:
    faults = faults_from_mapping({"jams": [{"nut": 1, "index": 2, "start": 0.01}]}, 3, "f")
    nut, index = np.repeat([0, 1], 3), np.tile(np.arange(3), 2)
    assert not faults.jammed(0.0099, nut, index).any()
    np.testing.assert_array_equal(faults.jammed(0.01, nut, index), [0, 0, 0, 0, 0, 1])
    with pytest.raises(ConfigError, match=r"f\.jams\[0\]\.start"):
        faults_from_mapping({"jams": [{"nut": 1, "index": 2, "start": -1.0}]}, 3, "f")
    with pytest.raises(ConfigError, match="index"):
        faults_from_mapping({"jams": [{"nut": 0, "index": 3, "start": 0.0}]}, 3, "f")


RIPPLE_SPACING = 0.5  # rad, helix parameter between neighbouring spheres
RIPPLE_STEP = 2e-6  # s, the converged step of the time-step study (docs/model.md)


def _screw_torque_after_ramp(faults: Faults) -> tuple[DynamicModel, np.ndarray, np.ndarray, float]:
    """6 spheres per nut, 0.5 rad apart, 300 N, speed ramped to 4000 rpm in 1 ms, 13 ms in all:
    the spheres' moment on the screw and the screw speed after 3 ms, and the mean contact angle."""
    count = 6
    screw = dataclasses.replace(
        BASE.screw,
        balls_per_nut=count,
        balls_total_per_nut=count,
        loaded_turns=count * RIPPLE_SPACING / (2.0 * math.pi),
    )
    model = DynamicModel(
        dataclasses.replace(BASE, screw=screw),
        temperature=293.15,
        time_step=RIPPLE_STEP,
        jacobian_interval=10,
        faults=faults,
    )
    state = model.initial_state(300.0)
    torque, speed = [], []
    for k in range(round(13e-3 / RIPPLE_STEP)):
        x = min(k * RIPPLE_STEP / 1e-3, 1.0)
        state, report = model.step(state, Commands(419.0 * x * x * (3.0 - 2.0 * x), 300.0))
        if state.time > 3e-3:
            torque.append(report.screw_torque)
            speed.append(state.screw_speed)
    ev = report.contacts
    return model, np.array(torque), np.array(speed), float(ev.contact_angle[ev.active].mean())


def test_spall_makes_the_torque_ripple_at_the_sphere_pass_frequency() -> None:
    """A spall on the nut flank N1 modulates the drag torque once per passing sphere. Oracle
    (rolling kinematics, screw = rotating inner race, nut = still outer race): the sphere train
    turns relative to the nut at Omega/2 (1 - r_b cos alpha / r_m), so spheres RIPPLE_SPACING
    apart pass the spall with the period RIPPLE_SPACING / that rate. The ripple's
    autocorrelation peaks at that lag; without the spall there is hardly any ripple."""
    spall = RacewaySpall(half_groove="N1", centre=1.25, width=0.3, depth=3e-6)
    model, torque, speed, alpha = _screw_torque_after_ramp(Faults(spalls=(spall,)))
    _, healthy, _, _ = _screw_torque_after_ramp(Faults())
    geom = model.geometry
    train = (
        0.5 * float(speed.mean()) * (1.0 - geom.ball_radius * math.cos(alpha) / geom.pitch_radius)
    )
    period = RIPPLE_SPACING / train  # s
    ripple = torque - torque.mean()
    assert ripple.std() > 5.0 * healthy.std()
    correlation = np.correlate(ripple, ripple, "full")[len(ripple) - 1 :]
    lags = np.arange(len(correlation)) * RIPPLE_STEP
    window = (lags > 0.3 * period) & (lags < 1.6 * period)  # harmonics peak at period / k
    found = float(lags[window][np.argmax(correlation[window])])
    assert found == pytest.approx(period, rel=0.03)
