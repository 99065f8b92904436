"""Calibration: recovers a known parameter from synthetic data; reads and rejects CSV targets."""

from pathlib import Path

import pytest

from ballscrew_twin.calibration import (
    Target,
    calibrate,
    read_targets,
    with_parameters,
    write_config,
)
from ballscrew_twin.cli import RPM
from ballscrew_twin.errors import ConfigError
from ballscrew_twin.models.base import OperatingPoint
from ballscrew_twin.models.steady import SteadyStateModel
from ballscrew_twin.params import load_config


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
