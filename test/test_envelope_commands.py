"""Every command answers inside the validity envelope (docs/model.md section 13) or says why
not: a clamp comes with a note, a refusal with a one-line error; never a silent number."""

from __future__ import annotations

import csv
import json
from fractions import Fraction
from pathlib import Path

import pytest
import yaml

from ballscrew_twin.cli import main
from ballscrew_twin.models.base import OperatingPoint
from ballscrew_twin.models.validity import (
    DEFAULT_MIN_TEMPERATURE,
    ValidityEnvelope,
    clamp_operating_point,
)
from ballscrew_twin.params import load_config
from ballscrew_twin.units import celsius_to_kelvin

ROOT = Path(__file__).resolve().parents[1]

#: Inputs beyond the envelope, in command-line units (rpm, C, N).
OUTSIDE = [
    ["--speed", "20000", "--temperature", "20", "--preload", "1500"],
    ["--speed", "1e9", "--temperature", "20", "--preload", "1500"],
    ["--speed=-1e9", "--temperature", "20", "--preload", "1500"],
    ["--speed", "100", "--temperature", "1e6", "--preload", "1500"],
    ["--speed", "100", "--temperature", "-45", "--preload", "1500"],
    ["--speed", "100", "--temperature", "20", "--preload", "20000"],
    ["--speed", "100", "--temperature", "20", "--preload", "1500", "--axial-load=-2e4"],
    ["--speed", "100", "--temperature", "293", "--preload", "1500"],
    ["--speed", "100", "--temperature", "-300", "--preload", "1500"],
    ["--speed", "nan", "--temperature", "20", "--preload", "1500"],
    ["--speed", "100", "--temperature", "inf", "--preload", "1500"],
    ["--speed", "100", "--temperature", "20", "--preload", "-1"],
]


@pytest.mark.parametrize("model", ["zhou", "steady"])
@pytest.mark.parametrize("args", OUTSIDE, ids=[" ".join(a) for a in OUTSIDE])
def test_drag_outside_the_envelope_is_never_silent(
    capsys: pytest.CaptureFixture[str], args: list[str], model: str
) -> None:
    code = main(["drag", *args, "--model", model, "--json"])
    printed = capsys.readouterr()
    if code == 2:
        assert "error:" in printed.err and len(printed.err.strip().splitlines()) == 1
        assert printed.out == ""
        return
    assert code == 0
    data = json.loads(printed.out)
    notes = [n for n in data["notes"] if n.startswith("validity:")]
    assert notes and all(n in printed.err for n in notes)
    op = data["operating_point"]
    env = ValidityEnvelope.for_config(load_config())
    assert abs(op["screw_speed_rad_s"]) <= env.max_speed
    assert env.min_temperature <= op["temperature_K"] <= env.max_temperature
    assert op["preload_N"] <= env.max_preload and abs(op["axial_load_N"]) <= env.max_axial_load


def test_kelvin_typed_as_celsius_gets_the_hint(capsys: pytest.CaptureFixture[str]) -> None:
    args = ["drag", "--speed", "100", "--temperature", "293", "--preload", "1500"]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert "kelvin" in err and "19.85 C" in err


def test_speed_far_beyond_is_clamped_not_a_solver_error(
    capsys: pytest.CaptureFixture[str],
) -> None:
    args = ["drag", "--speed", "1e9", "--temperature", "20", "--preload", "1500", "--json"]
    assert main(args) == 0
    out = capsys.readouterr()
    assert "Jacobian" not in out.err and "exceeds 1884.96 rad/s" in out.err
    assert json.loads(out.out)["drag_torque_Nm"] > 0.0


def test_the_envelope_edges_typed_in_celsius_are_inside(
    capsys: pytest.CaptureFixture[str],
) -> None:
    for celsius, kelvin in (("-40", 233.15), ("100", 373.15)):
        args = ["drag", "--speed", "100", "--temperature", celsius, "--preload", "1500"]
        assert main([*args, "--model", "zhou", "--json"]) == 0
        data = json.loads(capsys.readouterr().out)
        assert data["operating_point"]["temperature_K"] == kelvin
        assert not [n for n in data["notes"] if n.startswith("validity:")]


@pytest.mark.parametrize("hundredths", range(-27315, 50001, 997))
def test_celsius_to_kelvin_is_the_float_nearest_the_exact_sum(hundredths: int) -> None:
    celsius = hundredths / 100.0
    exact = Fraction(str(celsius)) + Fraction("273.15")
    assert celsius_to_kelvin(celsius) == float(exact)


def test_the_nodes_lower_limit_accepts_minus_40_celsius() -> None:
    """The twin node's limit of -40 C (233.15 K) holds exactly once converted here."""
    from ballscrew_twin.ros.inputs import InputLimits, check_temperature

    assert celsius_to_kelvin(-40.0) == 233.15 == DEFAULT_MIN_TEMPERATURE
    assert check_temperature(celsius_to_kelvin(-40.0), InputLimits()) is None
    op = OperatingPoint(screw_speed=1.0, temperature=celsius_to_kelvin(-40.0), preload=0.0)
    assert clamp_operating_point(op, ValidityEnvelope.for_config(load_config()))[1] == ()


def test_sweep_refuses_kelvin_and_says_when_it_clamps(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "s.csv"
    base = ["sweep", "--model", "zhou", "--out", str(out), "--no-plot", "--quiet"]
    assert main([*base, "--temperature", "20,293"]) == 2
    assert "kelvin" in capsys.readouterr().err
    assert main([*base, "--speed", "100,20000", "--workers", "1"]) == 0
    assert "1 of 2 points were outside the validity envelope" in capsys.readouterr().err
    with out.open(encoding="utf-8") as handle:
        rows = list(csv.DictReader(handle))
    assert ["validity:" in r["notes"] for r in rows] == [False, True]


def test_scene_leaving_the_envelope_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    scene = yaml.safe_load((ROOT / "config/scenes/catalog_check.yaml").read_text("utf-8"))
    scene["commands"]["temperature"] = {"points": [[0.0, 293.15], [60.0, 400.0]]}
    path = tmp_path / "hot.yaml"
    path.write_text(yaml.safe_dump(scene), encoding="utf-8")
    assert main(["scene", str(path), "--out", str(tmp_path / "o"), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert str(path) in err and "temperature = 400 K is outside" in err


def test_simulate_refuses_a_scenario_outside_the_envelope(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    data = yaml.safe_load((ROOT / "config/scenarios/short_check.yaml").read_text("utf-8"))
    data["preload"] = 6000.0
    data["config"] = str(ROOT / "config" / "paper_screw_calibrated.yaml")
    path = tmp_path / "heavy.yaml"
    path.write_text(yaml.safe_dump(data), encoding="utf-8")
    assert main(["simulate", "--scenario", str(path), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert str(path) in err and "preload = 6000 N exceeds 5000 N" in err


def test_calibrate_refuses_targets_outside_the_envelope(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    data = tmp_path / "targets.csv"
    rows = "speed_rpm,temperature_C,preload_N,torque_Nm\n100,20,1500,0.02\n"
    for bad, words in (
        ("100,20,20000,0.05\n", "preload = 20000 N exceeds 5000 N"),
        ("20000,20,1500,0.05\n", "exceeds 1884.96 rad/s"),
        ("100,293,1500,0.02\n", "looks like a value in kelvin"),
    ):
        data.write_text(rows + bad, encoding="utf-8")
        assert main(["calibrate", "--data", str(data)]) == 2
        err = capsys.readouterr().err
        assert str(data) in err and words in err and len(err.strip().splitlines()) == 1


def test_bench_data_refuses_a_profile_outside_the_envelope(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    scene = yaml.safe_load((ROOT / "config/bench_scenes/healthy.yaml").read_text("utf-8"))
    scene["profile"][2]["temperature"] = 450.0
    scene["profile"][3]["speed"] = 1950.0
    path = tmp_path / "hot.yaml"
    path.write_text(yaml.safe_dump(scene), encoding="utf-8")
    out = tmp_path / "bag"
    assert main(["bench-data", "generate", "--scene", str(path), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert str(path) in err and "temperature = 450 K is outside" in err
    assert "|screw_speed| = 1950 rad/s exceeds" in err and not out.exists()


def test_report_refuses_a_grid_beyond_the_screws_critical_speed(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    data = yaml.safe_load((ROOT / "config/paper_screw_calibrated.yaml").read_text("utf-8"))
    data["screw"]["critical_speed"] = 50.0  # rad/s, below the report's speeds
    config = tmp_path / "slow.yaml"
    config.write_text(yaml.safe_dump(data), encoding="utf-8")
    out = tmp_path / "report"
    assert main(["report", "paper", "--out", str(out), "--config", str(config), "--quick"]) == 2
    err = capsys.readouterr().err
    assert str(config) in err and "exceeds 50 rad/s" in err and not out.exists()
