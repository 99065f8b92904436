"""``ballscrew-twin sweep``: dimensions, points, failed points, and the same file from local
processes and from a Dask cluster on loopback."""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import numpy as np
import pytest
from conftest import SavedFigures

from ballscrew_twin.cli import main
from ballscrew_twin.commands.sweep import (
    SweepTask,
    evaluate_point,
    grid_points,
    parameter_unit,
    parse_dimension,
    random_points,
    run_sweep,
    with_overrides,
)
from ballscrew_twin.errors import ConfigError, SweepError
from ballscrew_twin.params import load_config

CONFIG = load_config()
RPM = 2.0 * math.pi / 60.0


def _rows(path: Path) -> list[dict[str, str]]:
    with path.open(encoding="utf-8") as handle:
        return list(csv.DictReader(handle))


def test_dimension_forms_in_si() -> None:
    speed = parse_dimension("screw_speed", "60,120", "rad/s", lambda rpm: rpm * RPM)
    assert speed.values == pytest.approx((2.0 * math.pi, 4.0 * math.pi))
    celsius = parse_dimension("temperature", "lin:-20:60:3", "K", lambda c: c + 273.15)
    assert celsius.values == pytest.approx((253.15, 293.15, 333.15))
    log = parse_dimension("lubricant.eyring_stress", "log:1e5:1e7:3", "Pa")
    assert log.values == pytest.approx((1e5, 1e6, 1e7))
    ranged = parse_dimension("preload", "loguniform:10:1000", "N")
    assert ranged.is_range and ranged.log and (ranged.low, ranged.high) == (10.0, 1000.0)


@pytest.mark.parametrize(
    ("spec", "message"),
    [
        ("1,x", "expected a number in N"),
        ("1,nan", "not a finite number"),
        ("lin:0:1", "expected lin:LO:HI:N"),
        ("lin:0:1:2.5", "whole number"),
        ("log:0:1:3", "LO, HI > 0"),
        ("uniform:5:1", "LO must be below HI"),
        ("loguniform:0:1", "LO > 0"),
        ("gauss:0:1", "unknown form"),
    ],
)
def test_bad_dimension_is_named(spec: str, message: str) -> None:
    with pytest.raises(SweepError, match=message) as info:
        parse_dimension("preload", spec, "N")
    assert "preload" in str(info.value)


def test_grid_is_the_cartesian_product_last_fastest() -> None:
    a = parse_dimension("preload", "1,2", "N")
    b = parse_dimension("axial_load", "10,20,30", "N")
    points = grid_points([a, b])
    assert [(p["preload"], p["axial_load"]) for p in points] == [
        (1.0, 10.0),
        (1.0, 20.0),
        (1.0, 30.0),
        (2.0, 10.0),
        (2.0, 20.0),
        (2.0, 30.0),
    ]
    with pytest.raises(SweepError, match="give --samples"):
        grid_points([parse_dimension("preload", "uniform:0:1", "N")])


def test_random_points_seeded_and_within_bounds() -> None:
    dims = [
        parse_dimension("preload", "uniform:100:3000", "N"),
        parse_dimension("lubricant.eyring_stress", "loguniform:1e5:1e7", "Pa"),
        parse_dimension("axial_load", "0,500", "N"),
    ]
    first = random_points(dims, 400, seed=3)
    assert first == random_points(dims, 400, seed=3)
    assert first != random_points(dims, 400, seed=4)
    preload = np.array([p["preload"] for p in first])
    tau = np.array([p["lubricant.eyring_stress"] for p in first])
    assert preload.min() >= 100.0 and preload.max() <= 3000.0
    assert tau.min() >= 1e5 and tau.max() <= 1e7
    # log-uniform: log10 of the draw is uniform on [5, 7], so its mean is 6 (400 draws: the
    # standard error is 0.58 / sqrt(400) = 0.029).
    assert np.mean(np.log10(tau)) == pytest.approx(6.0, abs=0.12)
    assert {p["axial_load"] for p in first} == {0.0, 500.0}


def test_a_count_below_one_is_refused_naming_the_option(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    dims = [parse_dimension("preload", "uniform:100:3000", "N")]
    with pytest.raises(SweepError) as err:
        random_points(dims, 0, seed=3)
    assert str(err.value) == "--samples = 0 is outside the allowed range [1, inf] -"
    task = SweepTask(model="zhou", mode="auto", config=load_config(None))
    with pytest.raises(SweepError) as err:
        run_sweep(task, dims, [], chunk_size=0)
    assert str(err.value) == "--chunk-size = 0 is outside the allowed range [1, inf] -"
    args = ["sweep", "--model", "zhou", "--speed", "100", "--workers", "0", "--quiet"]
    assert main([*args, "--out", str(tmp_path / "sweep.csv")]) == 2
    err_text = capsys.readouterr().err
    assert "--workers = 0 is outside the allowed range [1, inf] -" in err_text


def test_parameter_paths() -> None:
    assert parameter_unit(CONFIG, "lubricant.eyring_stress") == "Pa"
    assert parameter_unit(CONFIG, "materials.ball.young_modulus") == "Pa"
    with pytest.raises(SweepError, match="no field 'eyring'"):
        parameter_unit(CONFIG, "lubricant.eyring")
    with pytest.raises(SweepError, match="not a numeric field"):
        parameter_unit(CONFIG, "lubricant.viscosity_law")
    changed = with_overrides(CONFIG, {"contact.dry_friction_coefficient": 0.05})
    assert changed.contact.dry_friction_coefficient == 0.05
    assert changed.lubricant == CONFIG.lubricant
    with pytest.raises(ConfigError, match="eyring_stress"):
        with_overrides(CONFIG, {"lubricant.eyring_stress": 1e20})


def test_failed_and_clamped_points_are_rows(tmp_path: Path) -> None:
    out = tmp_path / "catalog.csv"
    code = main(
        [
            "sweep",
            "--model",
            "zhou",
            "--preload",
            "1500,8000",
            "--param",
            "lubricant.eyring_stress=1e6,1e20",
            "--workers",
            "1",
            "--quiet",
            "--out",
            str(out),
        ]
    )
    assert code == 0
    rows = _rows(out)
    assert [r["status"] for r in rows] == ["ok", "error", "ok", "error"]
    assert "eyring_stress" in rows[1]["error"] and "outside the allowed range" in rows[1]["error"]
    # Eq. 52 with mu = 0.002: 19.2 N mm at 1500 N (MODEL_NOTES, independent value); 8000 N is
    # beyond the 5000 N envelope and is evaluated at 5000 N (Eq. 52 is linear in preload).
    assert float(rows[0]["drag_torque_Nm"]) == pytest.approx(19.2e-3, rel=2e-3)
    assert float(rows[2]["drag_torque_Nm"]) == pytest.approx(19.2e-3 * 5000 / 1500, rel=2e-3)
    assert "validity: preload = 8000 N exceeds 5000 N" in rows[2]["notes"]
    assert rows[2]["preload_N"] == "8000.0"  # the requested point is recorded
    settings = json.loads(out.with_suffix(".json").read_text())
    assert settings["failed_points"] == 2 and settings["model"] == "zhou"
    assert len(settings["config_sha256"]) == 64
    assert out.with_suffix(".png").is_file()


def test_worker_of_another_version_refuses_points() -> None:
    point = {"screw_speed": 10.0, "temperature": 293.15, "preload": 500.0, "axial_load": 0.0}
    good = evaluate_point(SweepTask(model="zhou", mode="auto", config=CONFIG), point)
    assert good["status"] == "ok"
    old = evaluate_point(
        SweepTask(model="zhou", mode="auto", config=CONFIG, version="0.0.0"), point
    )
    assert old["status"] == "error" and "install the same version" in old["error"]


def test_same_csv_from_local_processes_and_dask_cluster(tmp_path: Path) -> None:
    from distributed import LocalCluster

    common = [
        "sweep",
        "--model",
        "steady",
        "--speed",
        "100,4000",
        "--temperature=20,60",
        "--preload",
        "0,1500",
        "--param",
        "lubricant.eyring_stress=5e5",
        "--chunk-size",
        "3",
        "--quiet",
        "--no-plot",
    ]
    local = tmp_path / "local.csv"
    assert main([*common, "--workers", "2", "--out", str(local)]) == 0
    with LocalCluster(
        host="127.0.0.1",
        protocol="tcp",
        dashboard_address=None,
        n_workers=2,
        processes=False,
        threads_per_worker=1,
    ) as cluster:
        remote = tmp_path / "dask.csv"
        assert main([*common, "--scheduler", cluster.scheduler_address, "--out", str(remote)]) == 0
    assert local.read_bytes() == remote.read_bytes()
    rows = _rows(local)
    assert len(rows) == 8
    # The zero-preload point at 4000 rpm and 60 C does not converge (docs/model.md, section 9):
    # a row with the solver's message, not a crashed sweep.
    for row in rows:
        if row["status"] == "ok":
            assert math.isfinite(float(row["drag_torque_Nm"])) and row["error"] == ""
        else:
            assert row["status"] == "error" and "did not converge" in row["error"]
    assert sum(r["status"] == "ok" for r in rows) >= 7
    settings = json.loads(remote.with_suffix(".json").read_text())
    assert settings["executor"].startswith("dask tcp://127.0.0.1")


def test_unreachable_scheduler_is_a_clear_error(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    code = main(
        [
            "sweep",
            "--model",
            "catalog",
            "--scheduler",
            "tcp://127.0.0.1:9",
            "--connect-timeout",
            "1",
            "--quiet",
            "--out",
            str(tmp_path / "x.csv"),
        ]
    )
    assert code == 2
    assert "cannot reach the Dask scheduler at tcp://127.0.0.1:9" in capsys.readouterr().err


def test_grid_plot_is_curves_per_temperature_in_panels_per_preload(
    tmp_path: Path, saved_figures: SavedFigures
) -> None:
    out = tmp_path / "grid.csv"
    grid = ["--speed", "100,1000,3000", "--temperature=20,60", "--preload", "500,1500"]
    assert (
        main(["sweep", "--model", "steady", *grid, "--workers", "1", "--quiet", "--out", str(out)])
        == 0
    )
    assert saved_figures.paths() == [str(out.with_suffix(".png"))]
    assert out.with_suffix(".png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert saved_figures.missing_units() == []
    fig = saved_figures.saved[0][0]
    panels = [ax for ax in fig.axes if ax.get_visible()]
    assert [ax.get_title() for ax in panels] == ["preload = 500 N", "preload = 1500 N"]
    rows = _rows(out)
    for ax, preload in zip(panels, (500.0, 1500.0), strict=True):
        assert [line.get_label() for line in ax.lines] == [
            "temperature = 20 °C",
            "temperature = 60 °C",
        ]
        for line, celsius in zip(ax.lines, (20.0, 60.0), strict=True):
            expected = [
                float(r["drag_torque_Nm"]) * 1e3
                for r in rows
                if float(r["preload_N"]) == preload
                and float(r["temperature_K"]) == pytest.approx(celsius + 273.15)
            ]
            np.testing.assert_allclose(line.get_xdata(), [100.0, 1000.0, 3000.0])
            np.testing.assert_allclose(line.get_ydata(), expected)


def test_random_plot_is_a_heat_map(tmp_path: Path, saved_figures: SavedFigures) -> None:
    out = tmp_path / "random.csv"
    draw = ["--samples", "40", "--speed", "uniform:50:3000", "--temperature=uniform:-20:60"]
    assert (
        main(["sweep", "--model", "steady", *draw, "--workers", "1", "--quiet", "--out", str(out)])
        == 0
    )
    assert saved_figures.missing_units() == []
    fig = saved_figures.saved[0][0]
    heat = fig.axes[0]
    assert (heat.get_xlabel(), heat.get_ylabel()) == ("screw speed [rpm]", "temperature [°C]")
    (mesh,) = heat.collections
    cells = np.asarray(mesh.get_array())
    torque = np.array([float(r["drag_torque_Nm"]) for r in _rows(out)]) * 1e3
    # every cell is the mean of some points: within the points' range, and some cells filled
    filled = cells[np.isfinite(cells)]
    assert 0 < filled.size <= 40
    assert torque.min() - 1e-9 <= filled.min() and filled.max() <= torque.max() + 1e-9
    assert fig.axes[1].get_ylabel() == "mean drag torque [mN m]"
