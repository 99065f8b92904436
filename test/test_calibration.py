"""Calibration: recovers a known parameter from synthetic data with its uncertainty; reads and
rejects CSV targets; finds the steady segments of a bench bag; plot."""

import json
import math
from pathlib import Path

import numpy as np
import pytest
from conftest import SavedFigures
from scipy.optimize import curve_fit

from ballscrew_twin.bags.recording import BenchRecording, Series
from ballscrew_twin.calibration import (
    SteadyCriteria,
    Target,
    calibrate,
    parameter_covariance,
    read_targets,
    steady_segments,
    with_parameters,
    write_config,
)
from ballscrew_twin.cli import main
from ballscrew_twin.errors import ConfigError
from ballscrew_twin.health.bench_data import SAMPLE_DIR as SAMPLES
from ballscrew_twin.models.base import OperatingPoint
from ballscrew_twin.models.steady import SteadyStateModel
from ballscrew_twin.params import load_config
from ballscrew_twin.units import RPM


def test_recovers_the_eyring_stress_that_made_the_data(tmp_path: Path) -> None:
    config = load_config()
    truth = with_parameters(config, {"eyring_stress": 1.3e6})
    points = [
        OperatingPoint(screw_speed=s * RPM, temperature=t + 273.15, preload=f)
        for s, t, f in ((100, 20, 800), (500, 0, 2000), (1000, 40, 1200))
    ]
    model = SteadyStateModel(truth)
    targets = [Target(p, model.evaluate(p).drag_torque) for p in points]
    start = with_parameters(config, {"eyring_stress": 3.0e6})
    result = calibrate(start, targets, ["eyring_stress"], progress=False)
    assert result.values["eyring_stress"] == pytest.approx(1.3e6, rel=1e-4)
    assert result.max_relative_error < 1e-6
    out = tmp_path / "fitted.yaml"
    write_config(result, "synthetic", out)
    assert load_config(out).lubricant.eyring_stress == pytest.approx(1.3e6, rel=1e-4)
    assert "synthetic" in out.read_text()


def test_reads_a_bench_table(tmp_path: Path) -> None:
    table = tmp_path / "bench.csv"
    table.write_text("speed_rpm,temperature_C,preload_N,torque_Nm\n100,20,1500,0.02\n")
    (target,) = read_targets(table)
    assert target.point.screw_speed == pytest.approx(100 * RPM)
    assert target.point.temperature == pytest.approx(293.15)
    assert target.torque == 0.02


@pytest.mark.parametrize(
    ("text", "word"),
    [
        ("speed_rpm,temperature_C,preload_N\n100,20,1500\n", "torque_Nm"),
        ("speed_rpm,temperature_C,preload_N,torque_Nm\n100,20,abc,0.02\n", ":2"),
        ("speed_rpm,temperature_C,preload_N,torque_Nm\n100,nan,1500,0.02\n", "non-finite"),
        ("speed_rpm,temperature_C,preload_N,torque_Nm\n", "no data"),
    ],
)
def test_bad_tables_are_rejected_with_a_reason(tmp_path: Path, text: str, word: str) -> None:
    table = tmp_path / "bad.csv"
    table.write_text(text)
    with pytest.raises(ConfigError) as err:
        read_targets(table)
    assert word in str(err.value) and "bad.csv" in str(err.value)


def test_unknown_parameter_is_rejected() -> None:
    with pytest.raises(ConfigError, match="viscosity_law"):
        calibrate(load_config(), [], ["viscosity_law"], progress=False)


def test_parameter_covariance_matches_curve_fit_on_a_linear_model() -> None:
    # Oracle: scipy's curve_fit, whose covariance (absolute_sigma=False) is s^2 (J^T J)^-1
    # with s^2 the residual variance about the fitted line.
    rng = np.random.default_rng(4)
    x = np.linspace(0.0, 3.0, 12)
    y = 0.7 + 1.9 * x + rng.normal(0.0, 0.05, x.size)
    jacobian = np.column_stack([np.ones_like(x), x])
    coefficients, oracle = curve_fit(lambda x, a, b: a + b * x, x, y, jac=lambda x, a, b: jacobian)
    residuals = coefficients[0] + coefficients[1] * x - y
    np.testing.assert_allclose(parameter_covariance(jacobian, residuals), oracle, rtol=1e-9)


def test_parameter_covariance_is_nan_when_the_fit_cannot_tell() -> None:
    square = np.array([[1.0, 0.0], [0.0, 2.0]])
    assert np.isnan(parameter_covariance(square, np.array([0.1, 0.1]))).all()  # m = n
    twins = np.array([[1.0, 1.0], [2.0, 2.0], [3.0, 3.0]])  # columns alike: singular
    assert np.isnan(parameter_covariance(twins, np.array([0.1, -0.1, 0.0]))).all()


def test_noisy_targets_give_an_uncertainty_that_covers_the_truth(tmp_path: Path) -> None:
    config = load_config()
    truth = with_parameters(config, {"eyring_stress": 1.3e6})
    model = SteadyStateModel(truth)
    noise = (0.01, -0.008, 0.004, -0.012, 0.006)  # relative, fixed
    points = [
        OperatingPoint(screw_speed=s * RPM, temperature=t + 273.15, preload=f)
        for s, t, f in (
            (100, 20, 800),
            (500, 0, 2000),
            (1000, 40, 1200),
            (300, 60, 1500),
            (50, 10, 2500),
        )
    ]
    targets = [
        Target(p, model.evaluate(p).drag_torque * (1.0 + e))
        for p, e in zip(points, noise, strict=True)
    ]
    start = with_parameters(config, {"eyring_stress": 3.0e6})
    result = calibrate(start, targets, ["eyring_stress"], progress=False)
    sigma = result.uncertainty["eyring_stress"]
    assert 0.0 < sigma < 0.2e6
    assert abs(result.values["eyring_stress"] - 1.3e6) < 3.0 * sigma
    predicted = [model.evaluate(p).drag_torque for p in points]  # the truth's, not the fit's
    np.testing.assert_allclose(result.predicted, predicted, rtol=0.05)


def _series(channel: str, time: np.ndarray, value: np.ndarray) -> Series:
    return Series(channel, f"/bench/{channel}", "std_msgs/msg/Float64", time, value)


def test_steady_segments_are_the_plateaus_of_a_recording() -> None:
    # 100 rad/s for 0-4 s, a 1 s ramp, 50 rad/s for 5-9 s; the temperature steps by 2 K at 7 s
    # (a second segment at 50 rad/s), noisy speed and torque, preload steady.
    rng = np.random.default_rng(0)
    t = np.arange(0.0, 9.0, 0.005)
    speed = np.interp(t, [0.0, 4.0, 5.0, 9.0], [100.0, 100.0, 50.0, 50.0])
    temperature = np.where(t < 7.0, 293.15, 295.15)
    torque = 0.02 + 1e-4 * speed
    recording = BenchRecording(
        path=Path("synthetic"),
        storage="mcap",
        start_ns=0,
        duration=9.0,
        channels={
            "torque": _series("torque", t, torque + rng.normal(0, 2e-4, t.size)),
            "speed": _series("speed", t, speed + rng.normal(0, 0.05, t.size)),
            "temperature": _series("temperature", t, temperature),
            "preload": _series("preload", t, np.full(t.size, 1500.0)),
        },
        truth=None,
        issues=(),
    )
    segments = steady_segments(recording, SteadyCriteria(window=1.0))
    spans = [(round(s.start, 2), round(s.stop, 2)) for s in segments]
    assert spans == [(0.0, 4.0), (5.0, 7.0), (7.0, 9.0)]
    assert [round(s.speed) for s in segments] == [100, 50, 50]
    assert [round(s.temperature, 2) for s in segments] == [293.15, 293.15, 295.15]
    for s, expected in zip(segments, (0.03, 0.025, 0.025), strict=True):
        assert s.torque == pytest.approx(expected, abs=3 * 2e-4 / math.sqrt(s.samples))


def test_calibrates_from_a_bench_bag_with_plot_and_targets(
    tmp_path: Path, saved_figures: SavedFigures, capsys: pytest.CaptureFixture[str]
) -> None:
    out, png, table = tmp_path / "a" / "fit.yaml", tmp_path / "b" / "fit.png", tmp_path / "t.csv"
    args = ["--data", str(SAMPLES / "healthy"), "--parameters", "eyring_stress"]
    files = ["--out", str(out), "--plot", str(png), "--save-targets", str(table), "--json"]
    assert main(["calibrate", *args, *files]) == 0
    printed = capsys.readouterr()
    assert "steady segment(s)" in printed.err and f"wrote {png}" in printed.err
    summary = json.loads(printed.out)  # stdout: the JSON only
    # the sample bag: 100 and 200 rpm at 1500 N, 20 -> 22 C (docs/bench_data.md, committed samples)
    speeds = {round(t["speed_rad_s"] / RPM) for t in summary["targets"]}
    assert speeds == {100, 200} and len(summary["targets"]) >= 3
    assert all(t["preload_N"] == pytest.approx(1500.0, abs=5.0) for t in summary["targets"])
    # the samples were made by the shipped parameter set (plus a 0.2 mN m torque bias)
    shipped = load_config().lubricant.eyring_stress
    assert summary["parameters"]["eyring_stress"] == pytest.approx(shipped, rel=0.05)
    assert summary["uncertainty"]["eyring_stress"] > 0.0
    assert out.is_file() and png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert saved_figures.paths() == [str(png)] and saved_figures.missing_units() == []
    again = read_targets(table)
    assert [t.torque for t in again] == pytest.approx(
        [t["target_Nm"] for t in summary["targets"]], rel=1e-5
    )


@pytest.mark.parametrize(
    ("extra", "expected"),
    [
        # a steady window not above zero, named with its range and unit
        (["--steady-window", "0"], "--steady-window = 0.0 is outside the allowed range (0, inf] s"),
        # a bag without steady running at that window
        (["--steady-window", "100"], "no steady segment"),
        # a bag without a needed topic, named
        (["--preload-topic", "/bench/no_load_cell"], "/bench/no_load_cell"),
    ],
)
def test_calibrate_refuses_bad_input_in_one_line_naming_it(
    extra: list[str], expected: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["calibrate", "--data", str(SAMPLES / "healthy"), *extra]) == 2
    err = capsys.readouterr().err.strip()
    assert expected in err and len(err.splitlines()) == 1
