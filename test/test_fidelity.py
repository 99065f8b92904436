"""Fidelity selection: the committed bounds file, the coverage rule, the choices and refusals."""

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

from ballscrew_twin.benchmarks.skips import RULES
from ballscrew_twin.errors import FidelityError
from ballscrew_twin.fidelity import (
    METRICS,
    Bounds,
    distinct_points,
    load_bounds,
    select,
    sphere_gap,
)
from ballscrew_twin.params import load_config
from ballscrew_twin.scene import scene_from_mapping

RPM = 2 * math.pi / 60


@pytest.fixture(scope="module")
def bounds() -> Bounds:
    return load_bounds()


@pytest.fixture(scope="module")
def config():  # type: ignore[no-untyped-def]
    return load_config()


def scene(speed: object = 100 * RPM, temperature: object = 293.15, **changes: object):  # type: ignore[no-untyped-def]
    data: dict = {
        "name": "t",
        "duration": 1.0,
        "output_rate": 10.0,
        "commands": {"speed": speed, "temperature": temperature, "preload": 1500.0},
        "outputs": ["drag"],
        "tolerance": {"drag_torque": 0.05},
    }
    data.update(changes)
    return scene_from_mapping(data, "test_scene.yaml")


def test_committed_bounds_file_structure(bounds: Bounds) -> None:
    assert bounds.command.startswith("ballscrew-twin bench skips")
    grid = bounds.grid
    assert min(grid["preload_N"]) == 0.0 and max(grid["preload_N"]) >= 3000.0
    assert min(grid["speed_rad_s"]) <= 100 * RPM * (1 + 1e-6)
    assert max(grid["speed_rad_s"]) >= 4000 * RPM * (1 - 1e-6)
    assert {round(t - 273.15) for t in grid["temperature_K"]} >= {-20, 20, 60}
    size = math.prod(len(v) for v in grid.values())
    assert bounds.rows.shape == (size, len(bounds.columns))
    # Every grid point appears once.
    points = {tuple(r) for r in bounds.rows[:, :3]}
    assert len(points) == size
    for rule in RULES:
        for metric in METRICS:
            values = bounds.column(f"{rule}.{metric}")
            finite = values[np.isfinite(values)]
            assert (finite >= 0.0).all(), f"{rule}.{metric}"
    for metric in METRICS:
        assert 0.0 < bounds.reference[metric] < 1.0
        assert 0.0 < bounds.dynamic[metric] < 1.0
    assert bounds.dynamic["step_cost_s"] > 0.0 and bounds.dynamic["time_step_s"] > 0.0
    for name in ("catalog", "steady_symmetric", "steady_full_vertical", "steady_full_horizontal"):
        assert bounds.cost[name] > 0.0
    # The symmetric reduction is exact on a vertical screw (all spheres equivalent).
    assert np.nanmax(bounds.column("symmetric_vertical.drag_torque")) < 1e-6


def synthetic() -> Bounds:
    """Two speeds x two preloads at one temperature, one rule column with chosen values."""
    rows = np.array(
        [
            [0.0, 10.0, 300.0, 0.1],
            [0.0, 100.0, 300.0, 0.2],
            [1000.0, 10.0, 300.0, 0.3],
            [1000.0, 100.0, 300.0, math.nan],
        ]
    )
    return Bounds(
        source="synthetic",
        command="test",
        grid={"preload_N": (0.0, 1000.0), "speed_rad_s": (10.0, 100.0), "temperature_K": (300.0,)},
        columns=("preload_N", "speed_rad_s", "temperature_K", "rule"),
        rows=rows,
        reference={},
        dynamic={},
        cost={},
    )


def test_bound_is_the_max_over_the_covering_grid_points() -> None:
    b = synthetic()

    def case(speed: float, preload: float, temperature: float = 300.0):  # type: ignore[no-untyped-def]
        s = scene(speed=speed, temperature=temperature)
        s = dataclasses.replace(s, preload=scene(speed=speed).preload.__class__((0.0,), (preload,)))
        return b.bound("rule", s)

    assert case(10.0, 0.0)[0] == 0.1  # on a grid point
    assert case(50.0, 0.0)[0] == 0.2  # between speeds: both neighbours
    assert case(5.0, 0.0)[0] == 0.1  # below the lowest speed: the lowest one
    assert case(10.0, 500.0)[0] == 0.3  # between preloads
    value, why = case(50.0, 500.0)
    assert value is None and "not measured" in why  # a failed point in range
    value, why = case(200.0, 0.0)
    assert value is None and "leaves the measured grid" in why
    value, why = case(10.0, 0.0, temperature=310.0)
    assert value is None and "temperature_K" in why


def test_tolerance_tighter_than_every_bound_is_refused(bounds: Bounds, config) -> None:  # type: ignore[no-untyped-def]
    tight = scene(tolerance={"drag_torque": 1e-6})
    with pytest.raises(FidelityError) as err:
        select(tight, bounds, config)
    message = str(err.value)
    assert "test_scene.yaml" in message and "no model meets" in message
    for name in ("catalog", "steady-symmetric", "steady-full", "dynamic"):
        assert name in message
    assert f"{bounds.dynamic['drag_torque']:.3g}" in message


def test_cheapest_model_within_tolerance(bounds: Bounds, config) -> None:  # type: ignore[no-untyped-def]
    loose = select(scene(tolerance={"drag_torque": 0.9}), bounds, config)
    assert loose.model == "catalog"
    steady = select(scene(tolerance={"drag_torque": 0.02}), bounds, config)
    assert steady.model == "steady-symmetric"
    catalog = next(c for c in steady.candidates if c.name == "catalog")
    assert catalog.rejected is not None and "> tolerance" in catalog.rejected
    assert steady.bounds["drag_torque"] is not None
    assert steady.bounds["drag_torque"] <= 0.02
    skipped = {s.rule for s in steady.skips if s.applied}
    assert {
        "per-sphere resolution",
        "fast sphere dynamics",
        "re-solving unchanged points",
    } <= skipped
    assert all(s.bound is not None or not s.applied for s in steady.skips)
    assert "steady-symmetric" in steady.report()


def test_per_sphere_output_rules_out_the_catalogue(bounds: Bounds, config) -> None:  # type: ignore[no-untyped-def]
    wanted = scene(
        outputs=["drag", "per_sphere"], tolerance={"drag_torque": 0.9, "contact_force": 0.9}
    )
    chosen = select(wanted, bounds, config)
    assert chosen.model != "catalog"
    catalog = next(c for c in chosen.candidates if c.name == "catalog")
    assert "per_sphere" in (catalog.rejected or "")


def test_a_fault_forces_the_dynamic_model(bounds: Bounds, config) -> None:  # type: ignore[no-untyped-def]
    faulty = scene(faults={"spheres": [{"nut": 0, "index": 3, "radius_change": 1e-6}]})
    chosen = select(faulty, bounds, config)
    assert chosen.model == "dynamic"
    assert all("faults" in (c.rejected or "") for c in chosen.candidates if c.name != "dynamic")
    # ... and with a varying temperature nothing can serve it.
    varying = scene(
        temperature={"points": [[0.0, 293.15], [1.0, 303.15]]},
        faults={"spheres": [{"nut": 0, "index": 3, "radius_change": 1e-6}]},
    )
    with pytest.raises(FidelityError, match="temperature varies"):
        select(varying, bounds, config)


def test_beyond_the_measured_grid_only_the_reference_remains(bounds: Bounds, config) -> None:  # type: ignore[no-untyped-def]
    fast = scene(speed=6000 * RPM)
    chosen = select(fast, bounds, config)
    assert chosen.model == "dynamic"
    for name in ("steady-symmetric", "steady-full"):
        steady = next(c for c in chosen.candidates if c.name == name)
        assert "leaves the measured grid" in (steady.rejected or "")


def test_unchanged_points_are_counted_once() -> None:
    ramp = scene(speed={"points": [[0.0, 10.0], [0.5, 20.0], [1.0, 10.0]]})
    assert distinct_points(ramp) == 6  # 0.0..0.5 rising, 0.6..1.0 mirror 0.4..0.0
    assert distinct_points(scene()) == 1


def test_sphere_gap_closes_when_the_spheres_are_packed(config) -> None:  # type: ignore[no-untyped-def]
    geom = config.screw
    assert sphere_gap(config, 293.15, 293.15) > 0.0
    helix = 2 * math.pi * geom.pitch_radius * geom.loaded_turns / math.cos(geom.helix_angle)
    packed_count = math.floor(helix / (2 * geom.ball_radius))
    packed = dataclasses.replace(
        config,
        screw=dataclasses.replace(
            geom, balls_per_nut=packed_count, balls_total_per_nut=max(packed_count, 1)
        ),
    )
    gap = sphere_gap(packed, 293.15, 293.15)
    assert 0.0 <= gap < 2 * geom.ball_radius / packed_count + 1e-9


def test_bad_bounds_files_are_named(tmp_path: Path) -> None:
    with pytest.raises(FidelityError, match="bench skips"):
        load_bounds(tmp_path / "missing.yaml")
    broken = tmp_path / "broken.yaml"
    broken.write_text("command: x\ngrid: {preload_N: [0]}\n")
    with pytest.raises(FidelityError, match=r"broken\.yaml"):
        load_bounds(broken)


def test_a_transient_bound_counts_only_when_the_commands_change(bounds: Bounds, config) -> None:  # type: ignore[no-untyped-def]
    with_transient = dataclasses.replace(
        bounds, reference={**bounds.reference, "transient_drag_torque": 0.03}
    )
    constant = select(scene(tolerance={"drag_torque": 0.02}), with_transient, config)
    assert constant.model == "steady-symmetric"
    ramp = scene(
        speed={"points": [[0.0, 100 * RPM], [1.0, 200 * RPM]]}, tolerance={"drag_torque": 0.02}
    )
    chosen = select(ramp, with_transient, config)
    assert chosen.model == "dynamic"
    steady = next(c for c in chosen.candidates if c.name == "steady-symmetric")
    assert steady.bounds["drag_torque"] == pytest.approx(
        0.03 + bounds.reference["drag_torque"], rel=1e-3
    )


def test_bench_skips_writes_what_the_models_give(tmp_path: Path, config) -> None:  # type: ignore[no-untyped-def]
    from ballscrew_twin.cli import main
    from ballscrew_twin.models.base import OperatingPoint
    from ballscrew_twin.models.catalog import CatalogModel
    from ballscrew_twin.models.steady import SteadyStateModel

    out = tmp_path / "bounds.yaml"
    args = ["--preloads", "1500", "--speeds", "1000", "--temperatures", "20"]
    assert main(["bench", "skips", *args, "--no-dynamic", "--quiet", "--out", str(out)]) == 0
    written = load_bounds(out)
    assert written.command.startswith("ballscrew-twin bench skips --preloads 1500")
    assert written.rows.shape[0] == 1
    errors = []
    for direction in (1, -1):
        op = OperatingPoint(screw_speed=direction * 1000 * RPM, temperature=293.15, preload=1500.0)
        steady = SteadyStateModel(config, mode="symmetric").evaluate(op).drag_torque
        catalog = CatalogModel(config).evaluate(op).drag_torque
        errors.append(abs(catalog - steady) / abs(steady))
        if direction == 1:
            assert written.column("drag_torque_Nm")[0] == pytest.approx(steady, rel=1e-6)
    # The larger error of the two directions of rotation.
    assert written.column("catalog_vertical.drag_torque")[0] == pytest.approx(max(errors), rel=1e-5)
    # Without the dynamic reference nothing is bounded against it: the selection refuses.
    with pytest.raises(FidelityError, match="not measured"):
        select(scene(speed=1000 * RPM), written, config)


def test_bounds_of_another_parameter_set_are_refused(bounds: Bounds, config) -> None:  # type: ignore[no-untyped-def]
    assert bounds.fingerprint  # the committed file names its parameter set
    renamed = dataclasses.replace(
        config,
        name="other name",
        screw=dataclasses.replace(config.screw, orientation="horizontal"),
    )
    select(scene(), bounds, renamed)  # same physics: accepted
    other = dataclasses.replace(
        config, contact=dataclasses.replace(config.contact, dry_friction_coefficient=0.2)
    )
    with pytest.raises(FidelityError, match="another parameter set"):
        select(scene(), bounds, other)


def test_bench_skips_refuses_a_grid_list_naming_the_option_and_its_unit(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from ballscrew_twin.cli import main

    out = tmp_path / "bounds.yaml"
    args = ["--preloads", "1500", "--speeds", "100,fast", "--temperatures", "20,nan"]
    assert main(["bench", "skips", *args, "--no-dynamic", "--quiet", "--out", str(out)]) == 2
    assert (
        "--speeds '100,fast': expected a number in rpm within [-inf, inf], got 'fast'"
        in capsys.readouterr().err
    )
    args[3] = "100"
    assert main(["bench", "skips", *args, "--no-dynamic", "--quiet", "--out", str(out)]) == 2
    assert (
        "--temperatures '20,nan': 'nan' is not a finite number (allowed range [-inf, inf] C)"
        in capsys.readouterr().err
    )
    assert not out.exists()
