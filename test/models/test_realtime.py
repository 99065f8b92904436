"""The real-time model: per-sphere states, signs, axial load, clamping, bad input, no solver."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from ballscrew_twin.errors import MapError, OperatingPointError
from ballscrew_twin.models.base import MECHANISMS, OperatingPoint, TimeSteppingModel, TwinOutput
from ballscrew_twin.models.realtime import RealTimeModel
from ballscrew_twin.models.steady import SteadyStateModel
from ballscrew_twin.models.steady_map import load_map
from ballscrew_twin.params import TwinConfig, load_config

RPM = 2.0 * math.pi / 60.0
TICK = 1e-3


@pytest.fixture(scope="module")
def config() -> TwinConfig:
    return load_config(None)


@pytest.fixture(scope="module")
def model(config: TwinConfig) -> RealTimeModel:
    return RealTimeModel(config)


@pytest.fixture(scope="module")
def steady(config: TwinConfig) -> SteadyStateModel:
    return SteadyStateModel(config, mode="symmetric")


def _point(rpm: float, celsius: float, preload: float, axial: float = 0.0) -> OperatingPoint:
    return OperatingPoint(
        screw_speed=rpm * RPM, temperature=celsius + 273.15, preload=preload, axial_load=axial
    )


def test_is_a_time_stepping_model(model: RealTimeModel) -> None:
    stepper: TimeSteppingModel = model
    op = _point(600, 25, 1200)
    stepper.reset(op)
    out = stepper.step(op, TICK)
    assert out.fidelity == "realtime-map" and stepper.name == "realtime_map"


def test_every_sphere_has_its_contacts(model: RealTimeModel, config: TwinConfig) -> None:
    out = model.step(_point(1200, 30, 1500), TICK)
    contacts = out.contacts
    assert contacts is not None
    count = config.screw.balls_per_nut
    assert len(contacts.sphere) == 2 * count * 4
    np.testing.assert_array_equal(np.unique(contacts.sphere), np.arange(2 * count))
    np.testing.assert_array_equal(np.bincount(contacts.nut), [4 * count, 4 * count])
    force = contacts.normal_force.reshape(2, count, 4)
    np.testing.assert_array_equal(force, np.broadcast_to(force[:, :1], force.shape))
    # Preloaded double nut: two loaded half grooves per sphere, the others free.
    assert np.all(contacts.in_contact.reshape(2 * count, 4).sum(axis=1) == 2)
    assert np.all(contacts.normal_force[~contacts.in_contact] < 1e-3 * contacts.normal_force.max())
    sliding = contacts.friction_force > 0
    np.testing.assert_allclose(
        contacts.lubricant_share[sliding] + contacts.dry_share[sliding], 1.0, rtol=1e-12
    )
    nut_sum = sum(out.nut_torque)
    assert out.drag_torque == pytest.approx(nut_sum, rel=1e-12)
    assert out.breakdown.total == pytest.approx(out.drag_torque, rel=1e-9)


@pytest.mark.parametrize(
    "op",
    [
        _point(-900, 45, 2200),  # reversed rotation
        _point(700, 15, 1000, axial=600),  # external load on the master nut
    ],
)
def test_agrees_with_the_steady_model(
    model: RealTimeModel, steady: SteadyStateModel, op: OperatingPoint
) -> None:
    out = model.step(op, TICK)
    ref = steady.evaluate(op)
    assert math.copysign(1.0, out.drag_torque) == math.copysign(1.0, op.screw_speed)
    assert out.drag_torque == pytest.approx(ref.drag_torque, rel=0.01)
    np.testing.assert_allclose(out.nut_torque, ref.nut_torque, rtol=0.01)
    assert ref.contacts is not None and out.contacts is not None
    count = len(out.contacts.sphere) // 8
    mine = out.contacts.normal_force.reshape(2, count, 4)[:, 0]
    np.testing.assert_allclose(mine, ref.contacts.normal_force.reshape(2, 4), rtol=0.02, atol=1e-6)


def test_clamps_outside_the_map_and_says_so(model: RealTimeModel) -> None:
    grid = model.map.grid
    cases = {
        "temperature": _point(1000, grid.temperature_max - 273.15 + 30, 1500),
        "rpm above": replace(_point(1000, 20, 1500), screw_speed=2 * grid.speed_max),
        "equivalent preload": _point(1000, 20, grid.preload_max + 500),
        "standstill": replace(_point(1000, 20, 1500), screw_speed=0.5 * grid.speed_min),
    }
    for words, op in cases.items():
        out = model.step(op, TICK)
        assert out.contacts is not None
        assert math.isfinite(out.drag_torque)
        assert all(np.isfinite(out.contacts.normal_force))
        assert any(words in note for note in out.notes[1:]), (words, out.notes)
    edge = model.step(replace(_point(1000, 20, 1500), screw_speed=grid.speed_max), TICK)
    beyond = model.step(cases["rpm above"], TICK)
    assert beyond.drag_torque == pytest.approx(edge.drag_torque, rel=1e-12)
    still = model.step(_point(0, 20, 1500), TICK)
    assert still.drag_torque == 0.0 and len(still.notes) == 1


def test_bad_input_is_named(model: RealTimeModel, config: TwinConfig) -> None:
    op = _point(500, 20, 1000)
    for dt in (0.0, -1e-3, math.nan, math.inf):
        with pytest.raises(ValueError, match="dt"):
            model.step(op, dt)
    with pytest.raises(OperatingPointError, match="screw_speed"):
        model.step(replace(op, screw_speed=math.nan), TICK)
    with pytest.raises(OperatingPointError, match="preload"):
        model.reset(replace(op, preload=-1.0))
    other = replace(
        config, screw=replace(config.screw, ball_roughness=2 * config.screw.ball_roughness)
    )
    with pytest.raises(MapError, match="ballscrew-twin map build --config"):
        RealTimeModel(other, load_map())


def test_steps_never_solve(model: RealTimeModel, monkeypatch: pytest.MonkeyPatch) -> None:
    """Stepping is a table look-up: the steady solver is never called, even through a
    reversal, a temperature drift and a preload change."""

    def forbidden(*_args: object, **_kwargs: object) -> None:
        raise AssertionError("the real-time model called the steady solver")

    monkeypatch.setattr(SteadyStateModel, "solve", forbidden)
    model.reset(_point(500, 20, 1500))
    for k in range(400):
        t = k * TICK
        op = _point(500 - 2500 * t, 20 + 50 * t, 1500 + 2000 * (t > 0.3))
        out = model.step(op, TICK)
        assert math.isfinite(out.drag_torque)
        if abs(op.screw_speed) > 10 * RPM:
            assert math.copysign(1.0, out.drag_torque) == math.copysign(1.0, op.screw_speed)


def _torques(out: TwinOutput) -> list[float]:
    return [out.drag_torque, *out.nut_torque, *(getattr(out.breakdown, m) for m in MECHANISMS)]


# Slow (blended), reversed, clamped, axial-loaded and repeated commands.
_SEQUENCE = [
    _point(1200, 30, 1500),
    _point(1200, 30, 1500),
    _point(0.01, 20, 900),
    _point(-700, 5, 2000, axial=-300),
    _point(-700, 5, 2000, axial=-300),
    _point(9000, 120, 5000),
    _point(1200, 30, 1500),
]


def test_cached_and_contact_free_steps_equal_a_fresh_interpolation(
    model: RealTimeModel, config: TwinConfig
) -> None:
    """Oracle: a new model per command (no cache); torques identical with or without contacts."""
    stepper = RealTimeModel(config, steady_map=model.map)
    for i, op in enumerate(_SEQUENCE):
        fresh = RealTimeModel(config, steady_map=model.map).evaluate(op)
        want = i % 3 != 1  # mix of requests with and without contact states
        out = stepper.step(op, TICK, contacts=want)
        np.testing.assert_allclose(_torques(out), _torques(fresh), rtol=1e-12, atol=0.0)
        assert out.notes == fresh.notes and out.operating_point == op
        plain = stepper.step(op, TICK, contacts=False)
        assert plain.contacts is None
        np.testing.assert_allclose(_torques(plain), _torques(fresh), rtol=1e-12, atol=0.0)
        full = stepper.step(op, TICK)
        assert full.contacts is not None and fresh.contacts is not None
        for name in ("normal_force", "contact_angle", "film_thickness", "slip_speed"):
            np.testing.assert_allclose(
                getattr(full.contacts, name), getattr(fresh.contacts, name), rtol=1e-12, atol=0.0
            )
        np.testing.assert_array_equal(full.contacts.in_contact, fresh.contacts.in_contact)


def test_a_bad_command_after_a_cached_one_is_still_refused(model: RealTimeModel) -> None:
    op = _point(800, 20, 1000)
    model.step(op, TICK, contacts=False)
    with pytest.raises(OperatingPointError):
        model.step(replace(op, screw_speed=math.nan), TICK, contacts=False)
    with pytest.raises(ValueError):
        model.step(op, math.nan)
