"""``bench screw``: the accuracy part on small tables of the new screw (the node part is the
measurement itself; test/ros/test_tables.py covers the node on a new screw)."""

from __future__ import annotations

import argparse
import math
from dataclasses import replace
from pathlib import Path

import pytest

from ballscrew_twin.benchmarks import screw
from ballscrew_twin.cli import main
from ballscrew_twin.models import map_grid, map_store
from ballscrew_twin.models import steady_map as sm
from ballscrew_twin.models.base import OperatingPoint
from ballscrew_twin.models.steady import SteadyStateModel
from ballscrew_twin.params import load_config
from ballscrew_twin.units import RPM

NEW_SCREW = Path(__file__).resolve().parents[2] / "config" / "screw_32x10.yaml"


def test_continued_reference_is_the_steady_state_of_the_point() -> None:
    """The continuation only chooses the start: it ends on a converged steady state of the
    point, equal to a cold solve where the model has one solution (1500 N, 20 C)."""
    config = load_config(NEW_SCREW)
    model = SteadyStateModel(config, mode="symmetric", tolerance=1e-11)
    op = OperatingPoint(screw_speed=-80.0, temperature=293.15, preload=1500.0)
    continued = screw.continued(model, op, map_grid.grid_for(config).speed_min)
    assert continued.operating_point == op
    cold = SteadyStateModel(config, mode="symmetric", tolerance=1e-11).evaluate(op)
    assert continued.drag_torque == pytest.approx(cold.drag_torque, rel=1e-8)


def test_accuracy_rows_of_a_small_table(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    original = map_grid.grid_for

    def small(config: object, preview: bool = False) -> map_grid.MapGrid:
        return replace(original(config, preview), speed_nodes=5)  # type: ignore[arg-type]

    monkeypatch.setattr(map_grid, "grid_for", small)
    monkeypatch.setattr(screw, "grid_for", small)
    build = ["map", "build", "--config", str(NEW_SCREW), "--workers", "1", "--no-progress"]
    assert main([*build, "--preview"]) == 0
    capsys.readouterr()
    args = argparse.Namespace(
        config=str(NEW_SCREW), cache=str(tmp_path), no_node=True, points=12, seed=3
    )
    assert screw.run(args) == 0
    text = capsys.readouterr().out
    assert "accuracy at 12 random points" in text
    rows = [line for line in text.splitlines() if line.startswith("| preview |")]
    assert len(rows) == len(screw.PRELOAD_BANDS)
    points = [int(row.split("|")[3]) for row in rows]
    failed = int(text.split("; ")[1].split()[0])
    assert sum(points) + failed == 12
    assert not any("| full |" in line for line in text.splitlines())  # none built
    config = load_config(NEW_SCREW)
    grid = small(config, preview=True)
    table = sm.load_map(map_store.cached_map_path(config, grid))
    ops = screw.accuracy_points(table, config, 200, 1)
    assert all(0.0 <= op.preload <= screw.MAX_PRELOAD for op in ops)
    top = min(grid.speed_max, config.screw.critical_speed) * (1 + 1e-12)
    assert all(0.1 * RPM <= abs(op.screw_speed) <= top for op in ops)
    assert any(op.preload < 20.0 for op in ops) and not any(math.isnan(op.preload) for op in ops)
