"""``bench accuracy --quick``: it runs, writes its four outputs and measures sensible errors."""

from __future__ import annotations

import argparse
import csv
import math
from pathlib import Path

import pytest

from ballscrew_twin.benchmarks import accuracy
from ballscrew_twin.models.base import OperatingPoint, TorqueBreakdown, TwinOutput


def _run(out: Path) -> int:
    parser = argparse.ArgumentParser()
    accuracy.add_arguments(parser)
    return accuracy.run(parser.parse_args(["--quick", "--no-progress", "--out", str(out)]))


def test_quick_run_writes_every_output(tmp_path: Path) -> None:
    assert _run(tmp_path) == 0
    for name in ("accuracy_points.csv", "accuracy_summary.csv", "accuracy.png", "accuracy.md"):
        assert (tmp_path / name).stat().st_size > 0, name
    with (tmp_path / "accuracy_summary.csv").open() as handle:
        rows = list(csv.DictReader(handle))
    steady = {r["model"]: r for r in rows if r["part"] == "steady"}
    for model in ("catalog-literature", "catalog-zhou", "steady-symmetric", "realtime-map"):
        assert model in steady
        assert float(steady[model]["run_time_s"]) > 0.0
    # Independent oracle: on the vertical paper screw symmetric mode is exact.
    assert float(steady["steady-symmetric"]["drag_error_max"]) < 1e-6
    # The catalogue formulas know neither speed nor temperature: far from the reference.
    assert float(steady["catalog-literature"]["drag_error_max"]) > 0.05
    assert float(steady["realtime-map"]["drag_error_max"]) < 0.01
    transient = [r for r in rows if r["part"] == "transient" and r["model"] == "realtime-map"]
    assert transient and all(float(r["drag_error_max"]) < 0.05 for r in transient)
    low = [r for r in rows if r["part"] == "low preload" and r["model"] == "realtime-map"]
    assert [r["scene"].split(" ")[0] for r in low] == ["0-20", "20-100", "100-200"]
    table = (tmp_path / "accuracy.md").read_text()
    assert "| realtime-map |" in table.replace("| realtime-map-half |", "")


def test_errors_of_an_exact_and_of_a_scaled_answer() -> None:
    op = OperatingPoint(screw_speed=10.0, temperature=300.0, preload=1000.0)

    def output(torque: float) -> TwinOutput:
        return TwinOutput(
            drag_torque=torque,
            nut_torque=(torque / 2, torque / 2),
            breakdown=TorqueBreakdown(lubricant_shear=torque),
            fidelity="test",
            operating_point=op,
        )

    exact = accuracy.errors(output(0.02), output(0.02))
    assert exact["drag_error"] == 0.0 and math.isnan(exact["force_error"])
    assert accuracy.errors(output(0.021), output(0.02))["drag_error"] == pytest.approx(0.05)
