"""Baseline files: round trip, validation naming the field, the error model's formulas."""

from __future__ import annotations

import itertools
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from ballscrew_twin.errors import ConfigError
from ballscrew_twin.health.baseline import (
    BAND_REACH,
    ERROR_BAND_EDGES,
    SHAPE_REFERENCE_SPEED,
    SHIFT_EXTRAPOLATION,
    SPEED_BIN_COUNT,
    Baseline,
    load_baseline,
    speed_bin,
)
from ballscrew_twin.health.correction import LOG_SPEED_NODES, TEMPERATURE_NODES, ResidualSurface
from ballscrew_twin.params import load_config


def _fitted() -> Baseline:
    return replace(
        Baseline.nominal(load_config(None)),
        source="bench.mcap",
        torque_gain=1.01,
        torque_bias=2e-4,
        preload_scale=0.93,
        temperature_shift=-1.5,
        shape_slope=0.03,
        shape_curvature=-0.01,
        sensor_noise=2e-4,
        error_relative=0.012,
        error_bands=(0.03, 0.02, 0.01, 0.008, 0.012, 0.015),
        temperature_min=290.0,
        temperature_max=300.0,
        band_temperature_min=(290.0, 290.0, 292.0, 295.0, 296.0, 300.0),
        band_temperature_max=(300.0, 300.0, 299.0, 299.0, 300.0, 300.0),
        fit_rms=0.009,
        blocks=512,
    )


def test_a_baseline_survives_its_file(tmp_path: Path) -> None:
    baseline = _fitted()
    file = baseline.save(tmp_path / "unit.yaml")
    assert load_baseline(file) == baseline
    assert "# ballscrew_twin baseline" in file.read_text()


@pytest.mark.parametrize(
    ("text", "field"),
    [
        ("torque_gain: -1.0", "torque_gain"),
        ("preload_scale: .nan", "preload_scale"),
        ("error_bands: [0.01, x]", "error_bands"),
        ("colour: blue", "colour"),
        ("format: 7", "format"),
        ("band_temperature_min: [290.0]", "band_temperature_min"),
        ("band_temperature_max: [280, 280, 280, 280, 280, 280]", "min is above max"),
    ],
)
def test_a_bad_field_is_named(tmp_path: Path, text: str, field: str) -> None:
    good = _fitted().to_yaml().splitlines()
    key = text.split(":")[0]
    lines = [line for line in good if not line.startswith(f"{key}:")] + [text]
    file = tmp_path / "bad.yaml"
    file.write_text("\n".join(lines) + "\n", encoding="utf-8")
    with pytest.raises(ConfigError, match=field) as err:
        load_baseline(file)
    assert "bad.yaml" in str(err.value)


def test_a_baseline_of_another_screw_is_refused() -> None:
    config = load_config(None)
    other = replace(config, screw=replace(config.screw, lead=0.01))
    _fitted().check_config(config)
    with pytest.raises(ConfigError, match="commission again"):
        _fitted().check_config(other)


def test_shape_and_error_bands_follow_their_definitions() -> None:
    b = _fitted()
    speeds = np.array([3.0, SHAPE_REFERENCE_SPEED, 300.0])
    x = np.log10(speeds / SHAPE_REFERENCE_SPEED)
    np.testing.assert_allclose(b.shape(speeds), 1.0 + 0.03 * x - 0.01 * x * x, rtol=1e-15)
    assert b.shape(np.array([-30.0]))[0] == 1.0  # the shape depends on |speed|
    # one speed inside each band, and the sign does not matter
    inside = (
        [ERROR_BAND_EDGES[0] / 2]
        + [0.5 * (low + high) for low, high in itertools.pairwise(ERROR_BAND_EDGES)]
        + [2 * ERROR_BAND_EDGES[-1]]
    )
    assert [b.error_at(v, 295.0) for v in inside] == list(b.error_bands)
    assert b.error_at(-inside[2], 295.0) == b.error_bands[2]
    assert replace(b, error_bands=()).error_at(5.0, 295.0) == 0.012
    # below 3 rad/s the band saw the whole range, 290-300 K
    assert b.temperature_distance(295.0, 1.0) == 0.0
    assert b.temperature_distance(280.0, -1.0) == pytest.approx(10.0)
    assert b.temperature_distance(310.0, 1.0) == pytest.approx(10.0)
    # at 50 rad/s (30-100 rad/s) only 295-299 K, at 500 rad/s only 300 K
    assert b.temperature_distance(293.0, 50.0) == pytest.approx(2.0)
    assert b.temperature_distance(295.0, -500.0) == pytest.approx(5.0)
    assert math.isfinite(b.error_absolute)


def _with_surface() -> Baseline:
    shape = (len(LOG_SPEED_NODES), len(TEMPERATURE_NODES))
    values = np.zeros(shape)
    support = np.zeros(shape)
    values[6, 12] = -0.02  # x = -0.5 (9.5 rad/s), 293.15 K
    values[6, 13] = -0.0123456789012345  # written to the last digit
    support[5:8, 11:14] = 50.0
    support[5, 11] = 1.0 / 3.0
    return replace(_fitted(), surface=ResidualSurface(values, support))


def test_a_baseline_with_a_residual_surface_survives_its_file(tmp_path: Path) -> None:
    baseline = _with_surface()
    loaded = load_baseline(baseline.save(tmp_path / "unit.yaml"))
    assert loaded == baseline
    assert loaded != _fitted()


def test_the_surface_scales_the_drag_and_its_support_sets_the_error() -> None:
    b = _with_surface()
    node_speed = SHAPE_REFERENCE_SPEED * 10.0 ** LOG_SPEED_NODES[6]
    np.testing.assert_allclose(b.surface_factor(np.array([node_speed]), 293.15), 0.98)
    # half way to the next node along x: half the node's value (bilinear)
    half = SHAPE_REFERENCE_SPEED * 10.0 ** (0.5 * (LOG_SPEED_NODES[6] + LOG_SPEED_NODES[7]))
    np.testing.assert_allclose(b.surface_factor(np.array([half]), 293.15), 0.99)
    # where it was learnt: the band's error; where it never was: the unseen error added
    assert b.error_at(node_speed, 293.15) == b.error_bands[1]
    assert b.error_at(node_speed, 353.15) == pytest.approx(math.hypot(0.02, b.unseen_error))
    # 80 % of the way from a learnt node (x node 7) to one never taught (x node 8): 80 % of
    # the value there is the surface's continuation, and so is the unseen error's share
    toward = SHAPE_REFERENCE_SPEED * 10.0 ** (0.2 * LOG_SPEED_NODES[7] + 0.8 * LOG_SPEED_NODES[8])
    band = b.error_bands[int(np.searchsorted(ERROR_BAND_EDGES, toward))]
    assert b.error_at(toward, 293.15) == pytest.approx(math.hypot(band, 0.8 * b.unseen_error))
    assert _fitted().surface_factor(np.array([1.0, 2.0]), 300.0).tolist() == [1.0, 1.0]


@pytest.mark.parametrize(
    "text",
    ["surface: 3", "surface: {values: [[0.0]], support: [[0.0]]}", "surface: {values: x}"],
)
def test_a_malformed_surface_is_named(tmp_path: Path, text: str) -> None:
    file = tmp_path / "unit.yaml"
    file.write_text(_fitted().to_yaml() + text + "\n")
    with pytest.raises(ConfigError, match="surface"):
        load_baseline(file)


def test_saving_creates_the_folder(tmp_path: Path) -> None:
    # docs/health.md's `commission ... --out out/unit.yaml` on a fresh clone has no out/ yet.
    file = _fitted().save(tmp_path / "out" / "unit.yaml")
    assert load_baseline(file) == _fitted()


def test_a_reach_takes_the_temperatures_commissioned_at_nearby_speeds(tmp_path: Path) -> None:
    # the third band (10-30 rad/s) saw only 296-300 K; 32 rad/s (bin 35: 31.6-39.8 rad/s)
    # saw 260-300 K, 9 rad/s (bin 29: 7.9-10 rad/s) 280-290 K, no other bin anything
    low = [math.inf] * SPEED_BIN_COUNT
    high = [-math.inf] * SPEED_BIN_COUNT
    low[35], high[35], low[29], high[29] = 260.0, 300.0, 280.0, 290.0
    b = replace(
        _fitted(),
        band_temperature_min=(290.0, 290.0, 296.0, 260.0, 290.0, 290.0),
        band_temperature_max=(300.0, 300.0, 300.0, 300.0, 300.0, 300.0),
        bin_temperature_min=tuple(low),
        bin_temperature_max=tuple(high),
    )
    assert (speed_bin(32.0), speed_bin(31.0), speed_bin(9.0), speed_bin(-9.0)) == (35, 34, 29, 29)
    assert (speed_bin(0.0), speed_bin(1e-3), speed_bin(1e5)) == (0, 0, SPEED_BIN_COUNT - 1)
    own_band = replace(b, band_reach=0.0)
    assert b.band_reach == BAND_REACH and own_band.reached_range(20.0) is None
    assert own_band.nearest_commissioned(265.0, 20.0) == 296.0  # its own band alone
    reaching = replace(b, band_reach=0.2)
    # 20 rad/s reaches 12.6-31.7 rad/s: bin 35 (from 31.6 rad/s), not bin 29
    assert reaching.reached_range(-20.0) == (260.0, 300.0)
    assert reaching.nearest_commissioned(265.0, 20.0) == 265.0
    assert reaching.nearest_commissioned(250.0, -20.0) == 260.0
    # 15 rad/s reaches 9.5-23.8 rad/s: bin 29 only
    assert reaching.nearest_commissioned(265.0, 15.0) == 280.0
    # 100 rad/s reaches 63-158 rad/s: nothing seen there, so its band's range (30-100 rad/s)
    assert reaching.reached_range(100.0) is None
    assert reaching.nearest_commissioned(250.0, 100.0) == 260.0
    assert (
        replace(reaching, bin_temperature_min=(), bin_temperature_max=()).reached_range(20.0)
        is None
    )
    with pytest.raises(ConfigError, match="band_reach"):
        replace(b, band_reach=-0.1)
    with pytest.raises(ConfigError, match="fine speed bin"):
        replace(b, bin_temperature_min=tuple(low[:-1]), bin_temperature_max=tuple(high[:-1]))
    # the bins not seen are .inf and -.inf in the file and come back as such
    file = replace(reaching, source="unit").save(tmp_path / "unit.yaml")
    assert "-.inf" in file.read_text()
    assert load_baseline(file) == replace(reaching, source="unit")
    high[35] = -math.inf
    with pytest.raises(ConfigError, match="not seen"):
        replace(b, bin_temperature_max=tuple(high))


def test_the_shift_extrapolation_error_follows_its_definition() -> None:
    b = replace(_fitted(), band_temperature_min=(), band_temperature_max=())  # dT = -1.5 K
    assert b.nearest_commissioned(280.0, 50.0) == 290.0
    assert b.nearest_commissioned(295.0, -50.0) == 295.0
    assert b.nearest_commissioned(310.0, 500.0) == 300.0
    # with band ranges, the band of |speed|: 50 rad/s is in the fourth (30-100 rad/s)
    banded = replace(
        b,
        band_temperature_min=(290.0, 290.0, 290.0, 296.0, 290.0, 290.0),
        band_temperature_max=(300.0, 300.0, 300.0, 298.0, 300.0, 300.0),
    )
    assert banded.nearest_commissioned(293.0, -50.0) == 296.0
    assert banded.nearest_commissioned(299.0, 50.0) == 298.0
    assert banded.nearest_commissioned(293.0, 5.0) == 293.0
    assert b.extrapolation_error(-0.004) == pytest.approx(1.5 / SHIFT_EXTRAPOLATION * 0.004)
    assert replace(b, temperature_shift=0.0).extrapolation_error(0.004) == 0.0
    # the baseline's own scale: twice the shift's scale, half the term
    wider = replace(b, shift_extrapolation=2.0 * SHIFT_EXTRAPOLATION)
    assert wider.extrapolation_error(-0.004) == pytest.approx(0.5 * b.extrapolation_error(-0.004))


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"inertia": 0.0}, "baseline: inertia = 0.0 is outside the allowed range (0, inf] kg m^2"),
        ({"unseen_error": -0.01}, "baseline: unseen_error = -0.01 is outside the allowed range"),
        ({"sensor_noise": math.nan}, "baseline: sensor_noise: nan is not a finite number"),
        ({"torque_bias": math.inf}, "baseline: torque_bias: inf is not a finite number"),
        ({"settling_angle": -1.0}, "baseline: settling_angle = -1.0 is outside the allowed range"),
    ],
)
def test_a_baseline_number_out_of_range_is_refused_naming_it(
    change: dict[str, float], message: str
) -> None:
    """Through the package's one number check: the field, its value, unit and range."""
    with pytest.raises(ConfigError) as err:
        replace(_fitted(), **change)  # type: ignore[arg-type]
    assert str(err.value).startswith(message), str(err.value)
