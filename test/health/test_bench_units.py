"""Drawn bench units: spreads, parameter changes, the Dahl lag (closed form) and the unit table
against the steady model it is built from."""

from __future__ import annotations

import math
from dataclasses import fields, replace

import numpy as np
import pytest

from ballscrew_twin.errors import ConfigError
from ballscrew_twin.health.bench_units import (
    TABLE_PRELOAD_RATIO,
    BenchUnit,
    UnitSpread,
    UnitTorqueTable,
    draw_unit,
    presliding_reference,
    unit_config,
)
from ballscrew_twin.kernels.presliding import presliding_lag
from ballscrew_twin.models.base import OperatingPoint
from ballscrew_twin.models.steady import SteadyStateModel
from ballscrew_twin.params import load_config


def test_a_unit_is_reproducible_and_within_its_spreads() -> None:
    spread = UnitSpread()
    units = [draw_unit(seed) for seed in range(200)]
    assert draw_unit(7) == draw_unit(7) and draw_unit(7) != draw_unit(8)
    for name, half in (
        ("preload_scale", spread.preload),
        ("viscosity_scale", spread.viscosity),
        ("dry_friction_scale", spread.dry_friction),
        ("eyring_scale", spread.eyring_stress),
        ("torque_gain", spread.torque_gain),
        ("inertia_scale", spread.inertia),
    ):
        values = np.array([getattr(u, name) for u in units])
        assert np.all(np.abs(values - 1.0) <= half)
        # uniform over the band: its ends are reached (a draw that ignores the spread fails)
        assert np.max(np.abs(values - 1.0)) > 0.9 * half
    angles = np.array([u.presliding_angle for u in units])
    assert spread.presliding_angle[0] <= angles.min() and angles.max() <= spread.presliding_angle[1]


def test_unit_config_scales_exactly_the_unit_parameters() -> None:
    config = load_config(None)
    unit = BenchUnit(viscosity_scale=0.8, dry_friction_scale=1.3, eyring_scale=0.7)
    changed = unit_config(config, unit)
    lub, new = config.lubricant, changed.lubricant
    assert new.viscosity_reference == pytest.approx(0.8 * lub.viscosity_reference, rel=1e-15)
    assert new.viscosity_second == pytest.approx(0.8 * lub.viscosity_second, rel=1e-15)
    assert new.eyring_stress == pytest.approx(0.7 * lub.eyring_stress, rel=1e-15)
    assert changed.contact.dry_friction_coefficient == pytest.approx(
        1.3 * config.contact.dry_friction_coefficient, rel=1e-15
    )
    for f in fields(lub):
        if f.name not in ("viscosity_reference", "viscosity_second", "eyring_stress"):
            assert getattr(new, f.name) == getattr(lub, f.name)
    assert changed.screw == config.screw


@pytest.mark.parametrize(
    "values", [{"preload_scale": 0.0}, {"torque_gain": -1.0}, {"presliding_angle": math.nan}]
)
def test_an_impossible_unit_is_refused(values: dict[str, float]) -> None:
    (name,) = values
    with pytest.raises(ConfigError, match=rf"^bench unit\.{name}"):  # the field, named
        BenchUnit(**values)


def test_dahl_lag_follows_the_closed_form_at_constant_steady_torque() -> None:
    # dT/d|phi| = (T_ss - T) / phi_c from T0: T = T_ss + (T0 - T_ss) exp(-phi / phi_c).
    phi = np.linspace(0.0, 1.0, 401) ** 2  # uneven steps: the step is exact for any size
    steady = np.full_like(phi, 0.02)
    lagged = presliding_reference(steady, phi, 0.1, start=-0.02)
    exact = 0.02 + (-0.02 - 0.02) * np.exp(-phi / 0.1)
    np.testing.assert_allclose(lagged, exact, rtol=0, atol=1e-15)


def test_dahl_lag_after_a_reversal_settles_within_a_few_angles() -> None:
    # A reversal: the steady torque flips sign; the torque needs the rotation, not the time.
    phi = np.concatenate([np.linspace(0.0, 2.0, 201), np.linspace(2.0, 1.0, 101)[1:]])
    steady = np.where(np.arange(len(phi)) < 201, 0.02, -0.02)
    lagged = presliding_reference(steady, phi, 0.05)
    back = phi[200] - phi[201:]  # rotation since the reversal
    assert lagged[201] > 0.0  # still positive just after the reversal
    after = lagged[201:][back >= 5 * 0.05]
    assert np.all(np.abs(after + 0.02) <= 0.04 * math.exp(-5.0) + 1e-15)


def test_compiled_dahl_lag_equals_the_reference() -> None:
    rng = np.random.default_rng(3)
    steady = rng.normal(0.0, 0.02, 2000)
    angle = np.cumsum(rng.normal(0.0, 0.05, 2000))
    reference = presliding_reference(steady, angle, 0.07, start=0.01)
    compiled = presliding_lag(steady, angle, 0.07, 0.01)
    np.testing.assert_allclose(compiled, reference, rtol=1e-13, atol=1e-18)
    assert not np.allclose(compiled, presliding_reference(steady, angle, 0.08, start=0.01))


@pytest.fixture(scope="module")
def nominal_table() -> UnitTorqueTable:
    return UnitTorqueTable(load_config(None), BenchUnit(), (283.15, 303.15), (1000.0, 2000.0))


def test_unit_table_reproduces_its_units_steady_model_off_its_nodes() -> None:
    """The oracle: symmetric steady solves of the unit's own parameter set, at points drawn
    between the nodes over a cold-to-warm range (the viscosity changes fastest when cold)."""
    config = load_config(None)
    unit = replace(draw_unit(4025), stribeck_fraction=0.0)  # the steady model alone
    table = UnitTorqueTable(config, unit, (253.15, 303.15), (900.0, 2600.0))
    model = SteadyStateModel(unit_config(config, unit), mode="symmetric")
    rng = np.random.default_rng(3)
    speeds = np.exp(rng.uniform(math.log(0.05), math.log(350.0), 24))
    temperatures = rng.uniform(253.15, 303.15, 24)
    preloads = rng.uniform(900.0, 2600.0, 24)
    got = table.steady_torque(speeds, temperatures, preloads)
    want = [
        model.evaluate(OperatingPoint(screw_speed=w, temperature=t, preload=p)).drag_torque
        for w, t, p in zip(speeds, temperatures, preloads, strict=True)
    ]
    # log-linear between nodes 2.5 K, a factor 1.25 in preload and 1.27 in speed apart
    # (measured over 150 points of unit 4025 from -18 to 28 C: max 0.37 %)
    np.testing.assert_allclose(got, want, rtol=0.005)


def test_a_unit_is_the_same_unit_in_every_recording() -> None:
    """Tables built for two recordings with different temperature and preload ranges give the
    same torque (and Stribeck size) wherever both cover: the nodes lie on fixed lattices.
    Before, the nodes spread over each recording's range, and one unit differed between its
    commissioning and a later run by up to 3.6 % at -18 C (unit 4025)."""
    config = load_config(None)
    unit = replace(draw_unit(4025), stribeck_fraction=0.2, stribeck_speed=0.8)
    cold = UnitTorqueTable(config, unit, (254.0, 280.0), (1150.0, 1400.0))
    other = UnitTorqueTable(config, unit, (262.3, 301.0), (1000.0, 1700.0))
    assert not np.array_equal(cold.temperatures, other.temperatures)
    rng = np.random.default_rng(5)
    speeds = np.exp(rng.uniform(math.log(0.1), math.log(300.0), 40)) * rng.choice([-1, 1], 40)
    temperatures = rng.uniform(262.3, 280.0, 40)
    preloads = rng.uniform(1150.0, 1400.0, 40)
    np.testing.assert_allclose(
        cold.steady_torque(speeds, temperatures, preloads),
        other.steady_torque(speeds, temperatures, preloads),
        rtol=1e-9,  # the same cells; the interpolation's arithmetic starts at another node
    )


def test_unit_table_is_odd_in_speed_and_zero_at_standstill(
    nominal_table: UnitTorqueTable,
) -> None:
    speeds = np.array([-40.0, -0.001, 0.0, 0.001, 40.0])
    torque = nominal_table.steady_torque(speeds, np.full(5, 293.15), np.full(5, 1500.0))
    assert torque[2] == 0.0
    assert torque[0] == -torque[4] and torque[1] == -torque[3]


def test_stribeck_rise_is_added_as_its_formula() -> None:
    """T_st = fraction x |T_ss(10 rad/s, 20 C)| of the unit at the instant's contact preload:
    the oracle is a direct steady solve there, whatever the recording's temperatures."""
    config = load_config(None)
    preload = TABLE_PRELOAD_RATIO**33  # a node of the preload lattice (1578 N)
    unit = BenchUnit(stribeck_fraction=0.2, stribeck_speed=0.5)
    plain = UnitTorqueTable(config, BenchUnit(), (263.15, 263.15), (preload, preload))
    rising = UnitTorqueTable(config, unit, (263.15, 263.15), (0.7 * preload, preload))
    model = SteadyStateModel(unit_config(config, unit), mode="symmetric")
    op = OperatingPoint(screw_speed=10.0, temperature=293.15, preload=preload)
    reference = abs(model.evaluate(op).drag_torque)
    speeds = np.array([-1.0, 0.2, 0.5, 3.0])
    t = np.full(4, 263.15)
    f = np.full(4, preload)
    extra = np.sign(speeds) * 0.2 * reference * np.exp(-((speeds / 0.5) ** 2))
    np.testing.assert_allclose(
        rising.steady_torque(speeds, t, f) - plain.steady_torque(speeds, t, f),
        extra,
        rtol=1e-12,
        atol=1e-15,
    )
    # a lighter contact preload, a smaller breakaway torque
    lighter = rising.stribeck_reference(np.array([preload / TABLE_PRELOAD_RATIO]))
    assert 0.5 * reference < lighter[0] < reference
