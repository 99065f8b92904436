"""``ballscrew-twin scene``: selection, run and outputs against the models evaluated directly."""

import csv
import json
import math
from pathlib import Path

import numpy as np
import pytest
import yaml
from conftest import SavedFigures

from ballscrew_twin.cli import main
from ballscrew_twin.models.base import OperatingPoint
from ballscrew_twin.models.catalog import drag_torque_zhou
from ballscrew_twin.models.steady import SteadyStateModel
from ballscrew_twin.params import load_config

RPM = 2 * math.pi / 60


def write_scene(folder: Path, **changes: object) -> Path:
    data: dict = {
        "name": "test",
        "duration": 1.0,
        "output_rate": 4.0,
        "commands": {
            "speed": {"points": [[0.0, 100 * RPM], [0.5, 300 * RPM]]},
            "temperature": 293.15,
            "preload": 1500.0,
        },
        "outputs": ["drag", "per_nut"],
        "tolerance": {"drag_torque": 0.02},
    }
    data.update(changes)
    path = folder / "scene.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def read_csv(path: Path) -> list[dict[str, float]]:
    with path.open() as handle:
        return [{k: float(v) for k, v in row.items()} for row in csv.DictReader(handle)]


def test_steady_scene_matches_the_model_and_reuses_unchanged_points(tmp_path: Path) -> None:
    scene = write_scene(tmp_path)
    out = tmp_path / "out"
    assert main(["scene", str(scene), "--out", str(out), "--quiet"]) == 0
    selection = json.loads((out / "selection.json").read_text())
    assert selection["model"] == "steady-symmetric"
    assert selection["error_bounds"]["drag_torque"] <= 0.02
    assert any(s["rule"] == "fast sphere dynamics" and s["applied"] for s in selection["skips"])
    assert {c["model"] for c in selection["candidates"]} >= {"catalog", "steady-full", "dynamic"}
    # Samples at 0, 0.25, 0.5, 0.75, 1 s: the last three share one operating point.
    assert selection["run"]["evaluations"] == 3
    assert selection["run"]["operating_point_cache_hits"] == 2
    rows = read_csv(out / "timeseries.csv")
    assert [r["time_s"] for r in rows] == [0.0, 0.25, 0.5, 0.75, 1.0]
    model = SteadyStateModel(load_config())
    for row in rows:
        op = OperatingPoint(
            screw_speed=row["speed_command_rad_s"], temperature=row["temperature_K"], preload=1500.0
        )
        expected = model.evaluate(op)
        assert row["drag_torque_Nm"] == pytest.approx(expected.drag_torque, rel=1e-6)
        assert row["nut_master_Nm"] == pytest.approx(expected.nut_torque[0], rel=1e-6)
    assert rows[1]["speed_command_rad_s"] == pytest.approx(200 * RPM)
    data = np.load(out / "result.npz")
    assert data["drag_torque"].shape == (5,)
    assert (out / "scene.png").stat().st_size > 1000


def test_catalogue_scene_gives_eq_52(tmp_path: Path) -> None:
    scene = write_scene(
        tmp_path,
        commands={
            "speed": 100 * RPM,
            "temperature": 293.15,
            "preload": {"points": [[0, 1500.0], [1, 3000.0]]},
        },
        outputs=["drag"],
        tolerance={"drag_torque": 0.9},
    )
    out = tmp_path / "out"
    assert main(["scene", str(scene), "--out", str(out), "--quiet"]) == 0
    assert json.loads((out / "selection.json").read_text())["model"] == "catalog"
    screw = load_config().screw
    for row in read_csv(out / "timeseries.csv"):
        expected = drag_torque_zhou(
            row["preload_N"],
            0.002,
            screw.nominal_contact_angle,
            screw.pitch_radius,
            screw.ball_radius,
            screw.helix_angle,
        )
        assert row["drag_torque_Nm"] == pytest.approx(expected, rel=1e-9)


def test_scene_plot_shows_torques_in_mn_m(tmp_path: Path, saved_figures: SavedFigures) -> None:
    """scene.png: every axis carries a unit; the torque axis is in mN m and its curves are the
    written drag and nut torques (N m in the CSV) times 1000."""
    scene = write_scene(
        tmp_path,
        commands={
            "speed": 100 * RPM,
            "temperature": 293.15,
            "preload": {"points": [[0, 1500.0], [1, 3000.0]]},
        },
        outputs=["drag", "per_nut"],
        tolerance={"drag_torque": 0.9},
    )
    out = tmp_path / "out"
    assert main(["scene", str(scene), "--out", str(out), "--quiet"]) == 0
    assert saved_figures.paths() == [str(out / "scene.png")]
    assert saved_figures.missing_units() == []
    fig = saved_figures.saved[0][0]
    (torque_axes,) = [ax for ax in fig.axes if ax.get_ylabel().startswith("torque")]
    assert torque_axes.get_ylabel() == "torque [mN m]"
    rows = read_csv(out / "timeseries.csv")
    curves = {line.get_label(): np.asarray(line.get_ydata()) for line in torque_axes.lines}
    for label, column in (("drag", "drag_torque_Nm"), ("master nut", "nut_master_Nm")):
        # the CSV holds 10 significant digits
        np.testing.assert_allclose(curves[label], [1e3 * r[column] for r in rows], rtol=1e-9)
    assert min(curves["drag"]) > 1.0  # mN m: about 19 at 1500 N (Eq. 52), not 0.019
    assert (out / "scene.png").stat().st_size > 1000


def test_fault_scene_runs_the_dynamic_model_from_the_static_state(tmp_path: Path) -> None:
    """A zero-size defect forces the dynamic model without changing the physics: at t = 0 the
    contact forces are those of the steady model's static equilibrium (oracle)."""
    scene = write_scene(
        tmp_path,
        duration=2e-5,
        output_rate=1e5,
        commands={"speed": 0.0, "temperature": 293.15, "preload": 1500.0},
        faults={"spheres": [{"nut": 0, "index": 0, "radius_change": 0.0}]},
        outputs=["drag", "per_sphere"],
        tolerance={"drag_torque": 0.05, "contact_force": 0.05},
    )
    out = tmp_path / "out"
    assert main(["scene", str(scene), "--out", str(out), "--quiet"]) == 0
    selection = json.loads((out / "selection.json").read_text())
    assert selection["model"] == "dynamic"
    data = np.load(out / "result.npz")
    assert data["time"].shape == (3,)
    assert data["drag_torque"][0] == 0.0  # at rest
    assert np.isfinite(data["drag_torque"]).all()
    static = SteadyStateModel(load_config(), mode="symmetric").solve(
        OperatingPoint(screw_speed=0.0, temperature=293.15, preload=1500.0)
    )
    cs = static.output.contacts
    assert cs is not None
    force = data["normal_force"][0]
    for nut in (0, 1):
        for groove in range(4):
            rows = (data["contact_nut"] == nut) & (data["contact_half_groove"] == groove)
            want = cs.normal_force[(cs.nut == nut) & (cs.half_groove == groove)][0]
            assert force[rows] == pytest.approx(want, rel=1e-3, abs=1e-6 * cs.normal_force.max())


def test_bad_scene_exits_2_naming_the_file(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    scene = write_scene(tmp_path, commands={"speed": 1.0, "temperature": 20.0, "preload": 0.0})
    assert main(["scene", str(scene), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert "scene.yaml" in err and "temperature" in err and "kelvin" in err
    beyond = write_scene(
        tmp_path, faults={"spheres": [{"nut": 0, "index": 25, "radius_change": 1e-6}]}
    )
    assert main(["scene", str(beyond), "--out", str(tmp_path / "out")]) == 2
    assert "spheres[0].index" in capsys.readouterr().err  # the paper screw has 25 per nut
    tight = write_scene(tmp_path, tolerance={"drag_torque": 1e-7})
    assert main(["scene", str(tight), "--out", str(tmp_path / "out")]) == 2
    assert "no model meets" in capsys.readouterr().err


def test_time_stepping_models_step_at_most_1_ms_and_are_sampled_on_time(tmp_path: Path) -> None:
    from ballscrew_twin.commands.scene import REALTIME_STEP, _empty, run_time_stepping
    from ballscrew_twin.models.base import TorqueBreakdown, TwinOutput
    from ballscrew_twin.scene import load_scene

    class Recorder:
        """A TimeSteppingModel that returns its command's speed as the drag torque."""

        name = "recorder"

        def __init__(self) -> None:
            self.steps: list[tuple[float, float]] = []

        def reset(self, op: OperatingPoint) -> None:
            self.steps.clear()

        def step(self, op: OperatingPoint, dt: float) -> TwinOutput:
            self.steps.append((op.screw_speed, dt))
            return TwinOutput(
                drag_torque=op.screw_speed,
                nut_torque=(0.0, 0.0),
                breakdown=TorqueBreakdown(),
                fidelity="recorder",
                operating_point=op,
            )

    ramp = {"points": [[0.0, 10.0], [0.01, 20.0]]}
    scene = load_scene(
        write_scene(
            tmp_path,
            duration=0.01,
            output_rate=400.0,
            commands={"speed": ramp, "temperature": 293.15, "preload": 1500.0},
        )
    )
    result = _empty(scene, scene.output_times())
    model = Recorder()
    run_time_stepping(scene, model, lambda n: None, result)
    dts = [dt for _, dt in model.steps[1:]]
    assert max(dts) <= REALTIME_STEP * (1 + 1e-12)
    assert sum(dts) == pytest.approx(scene.duration)
    # Each sample holds the model's output at the sample's own time.
    assert result.drag_torque == pytest.approx(result.speed)
