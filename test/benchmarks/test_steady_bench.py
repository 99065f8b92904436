"""``bench steady`` prints both solvers side by side and, on request, their agreement and a
baseline solver of another checkout."""

from __future__ import annotations

import argparse
from pathlib import Path

import pytest

from ballscrew_twin.benchmarks import steady
from ballscrew_twin.benchmarks.steady import path_point
from ballscrew_twin.models.steady import SteadyStateModel
from ballscrew_twin.params import default_config_path, load_config


def test_both_solvers_are_printed_with_their_agreement(capsys: pytest.CaptureFixture[str]) -> None:
    args = argparse.Namespace(config=None, repeat=1, burst=1, baseline=None, agreement=3)
    assert steady.run(args) == 0
    text = capsys.readouterr().out
    for mode in ("symmetric", "full"):
        assert f"{mode:<9} previous   solver: cold" in text
        assert f"{mode:<9} structured solver: cold" in text
        assert f"{mode:<9} {steady.PATH_BRANCH} solver: cold" in text
    assert "cold: 3 points, 3 solved by both, 3 equal to 1e-9" in text
    assert "warm path: 3 points" in text


def test_a_baseline_model_is_timed_beside_the_solvers() -> None:
    config = load_config()
    baseline = SteadyStateModel(config, mode="symmetric")  # stands for another checkout's
    lines = steady._solver_lines(
        config, "symmetric", path_point(0), path_point(1), repeat=1, burst=2, baseline=baseline
    )
    names = [line.split()[1] for line in lines[:4]]
    assert names == ["previous", "baseline", "structured", steady.PATH_BRANCH]
    assert "faster than the previous, x" in lines[4] and "than the baseline" in lines[4]


def test_the_baseline_package_is_imported_under_its_own_name() -> None:
    root = Path(steady.__file__).resolve().parents[2]
    model = steady.baseline_model(str(root), str(default_config_path()), "full")
    assert type(model).__module__ == f"{steady.BASELINE_PACKAGE}.models.steady"
    assert type(model) is not SteadyStateModel
    assert model.resolved_mode() == "full"


def test_a_baseline_folder_without_the_package_is_refused(tmp_path: Path) -> None:
    with pytest.raises(SystemExit, match="no ballscrew_twin package there"):
        steady.baseline_model(str(tmp_path), str(default_config_path()), "full")
