"""The friction response table against the steady model of the scaled screw itself."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from ballscrew_twin.cli import main
from ballscrew_twin.errors import MapError
from ballscrew_twin.health.residuals import UnitTwin
from ballscrew_twin.models.base import OperatingPoint
from ballscrew_twin.models.friction_response import (
    DEFAULT_RESPONSE_PATH,
    _fill_along_speed,
    build_response,
    cached_response_path,
    ensure_response,
    find_response,
    load_response,
    scaled_config,
)
from ballscrew_twin.models.steady import SteadyStateModel
from ballscrew_twin.params import load_config

CONFIG_DIR = Path(__file__).resolve().parents[2] / "config"


def _solved(scales: tuple[float, float], speed: float, celsius: float, preload: float) -> float:
    """|drag torque| [N m] of the screw with mu_dry and tau_0 scaled, solved cold."""
    model = SteadyStateModel(scaled_config(load_config(None), scales), mode="symmetric")
    op = OperatingPoint(screw_speed=speed, temperature=273.15 + celsius, preload=preload)
    return abs(float(model.evaluate(op).drag_torque))


def test_the_packaged_table_is_the_shipped_screws_own() -> None:
    # rebuilt in this process, it is the file (a change of the model that moves it fails here)
    packaged = load_response(DEFAULT_RESPONSE_PATH)
    rebuilt = build_response(load_config(None), workers=1)
    assert packaged.fingerprint == rebuilt.fingerprint
    np.testing.assert_allclose(packaged.coefficients, rebuilt.coefficients, atol=1e-9)
    np.testing.assert_array_equal(packaged.filled, rebuilt.filled)


# Between nodes on every axis (nodes: 14 K apart from -40 C, speeds x2.7 from 0.01 rad/s,
# preloads x3 from 150 N); one scale at a time and both together.
POINTS = [
    ((0.75, 1.0), 3.0, 20.0, 1200.0),
    ((1.0, 1.25), 60.0, 0.0, 800.0),
    ((1.2, 0.8), 0.5, 35.0, 2000.0),
    ((0.8, 1.3), 150.0, 10.0, 2500.0),
]


@pytest.mark.parametrize(("scales", "speed", "celsius", "preload"), POINTS)
def test_the_response_follows_the_scaled_screw_between_nodes(
    scales: tuple[float, float], speed: float, celsius: float, preload: float
) -> None:
    table = find_response(load_config(None))
    assert table is not None
    solved = math.log(
        _solved(scales, speed, celsius, preload) / _solved((1.0, 1.0), speed, celsius, preload)
    )
    factor = table.log_factor(np.array([speed]), 273.15 + celsius, preload, np.log(scales))[0]
    assert abs(solved) > 0.03  # the scales matter here
    assert factor == pytest.approx(solved, abs=0.015)


def test_the_unit_twin_with_scales_is_the_scaled_screw() -> None:
    # the map and the response together against a solve of the scaled screw: within the
    # table's measured error (0.021 in ln T at +-20-30 % scales, both at once) and the map's
    config = load_config(None)
    twin = UnitTwin(config, friction_scales=(0.8, 1.25))
    drag = twin.drag(np.array([20.0]), 293.15, 1500.0)[0]
    solved = _solved((0.8, 1.25), 20.0, 20.0, 1500.0)
    assert drag == pytest.approx(solved, rel=0.025)
    assert UnitTwin(config).drag(np.array([20.0]), 293.15, 1500.0)[0] < 0.9 * solved


def test_a_table_for_other_parameters_is_not_used(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    other = load_config(CONFIG_DIR / "screw_32x10.yaml")
    assert find_response(other) is None
    # the paper screw's table under the other screw's name is refused by its fingerprint
    path = cached_response_path(other)
    path.parent.mkdir(parents=True)
    load_response(DEFAULT_RESPONSE_PATH).save(path)
    assert find_response(other) is None


def test_friction_scales_without_a_table_are_refused() -> None:
    twin = UnitTwin(load_config(None))
    twin.response = None  # as for a screw whose table was never built
    assert twin.adjusted(0.9, 1.0).drag(np.array([5.0]), 293.15, 1000.0)[0] > 0.0
    with pytest.raises(MapError, match="friction response"):
        twin.adjusted(0.9, 1.0, (0.9, 1.0))


def test_a_file_that_is_not_a_table_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "response.npz"
    path.write_bytes(b"not a table")
    with pytest.raises(MapError, match="cannot be read"):
        load_response(path)


def test_a_failed_node_takes_its_nearest_speed_node() -> None:
    table = np.arange(5.0)[:, None, None] * np.ones((5, 1, 2))
    failed = np.zeros((5, 1, 2), dtype=bool)
    failed[[1, 4], 0, 0] = True
    _fill_along_speed(table, failed)
    assert list(table[:, 0, 0]) == [0.0, 0.0, 2.0, 3.0, 3.0]
    assert list(table[:, 0, 1]) == [0.0, 1.0, 2.0, 3.0, 4.0]
    failed[:, 0, 1] = True
    with pytest.raises(MapError, match="every speed failed"):
        _fill_along_speed(table, failed)


def test_map_response_writes_a_table_of_the_screw(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    screw = CONFIG_DIR / "screw_32x10.yaml"
    args = ["map", "response", "--config", str(screw), "--workers", "1", "--no-progress"]
    assert main(args) == 0
    assert "528 nodes" in capsys.readouterr().out
    table = find_response(load_config(screw))  # from the user cache, under its fingerprint
    assert table is not None
    assert table.fingerprint != load_response(DEFAULT_RESPONSE_PATH).fingerprint
    assert main([*args[:-3], "--workers", "0"]) == 2


def test_a_missing_table_is_built_once(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    # what `commission` (and `detect` with a baseline that has friction scales) does first
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    other = load_config(CONFIG_DIR / "screw_32x10.yaml")
    table, built = ensure_response(other, workers=1)
    assert built == cached_response_path(other) and built.is_file()
    again, built_again = ensure_response(other, workers=1)
    assert built_again is None
    np.testing.assert_array_equal(again.coefficients, table.coefficients)
    # a cached file that cannot be read is passed over and built again
    built.write_bytes(b"truncated")
    assert find_response(other) is None
    assert ensure_response(other, workers=1)[1] == built
    assert find_response(other) is not None
