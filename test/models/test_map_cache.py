"""The table of any screw: its grid, the user cache, the search that refuses a table built for
other parameters, and the ``map`` command."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from ballscrew_twin.cli import main
from ballscrew_twin.models import map_build, map_grid, map_store
from ballscrew_twin.models import steady_map as sm
from ballscrew_twin.models.base import OperatingPoint
from ballscrew_twin.models.steady import SteadyStateModel
from ballscrew_twin.params import config_fingerprint, load_config

ROOT = Path(__file__).resolve().parents[2]
NEW_SCREW = ROOT / "config" / "screw_32x10.yaml"
RPM = 2.0 * math.pi / 60.0


@pytest.fixture(autouse=True)
def user_cache(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A user cache of this test alone."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    return tmp_path / "cache" / map_store.CACHE_FOLDER


def _tiny_map(config_fingerprint: str) -> sm.SteadyMap:
    """A map of the smallest buildable grid with constant tables (content is not read)."""
    grid = map_grid.MapGrid(speed_nodes=5, temperature_nodes=5, preload_nodes=5)
    coarse = grid.coarse()
    f = len(map_grid.CONTACT_FIELDS)
    shape = (2, grid.speed_nodes, grid.temperature_nodes, grid.preload_nodes)
    small = (2, coarse.speed_nodes, coarse.temperature_nodes, coarse.preload_nodes)
    return sm.SteadyMap(
        grid=grid,
        torque=np.full((*shape, 2, 6), 1e-3),
        contacts=np.ones((*small, 2, 4, f)),
        static=np.ones((*small[2:], 2, 4, f)),
        filled=np.zeros(shape, dtype=bool),
        fingerprint=config_fingerprint,
        orientation="vertical",
    )


def test_the_new_screw_loads_and_differs_from_the_paper_screw() -> None:
    config = load_config(NEW_SCREW)
    assert config.screw.balls_per_nut == 36
    assert math.degrees(config.screw.free_contact_angle) == pytest.approx(45.0, abs=0.05)
    assert config_fingerprint(config) != config_fingerprint(load_config(None))


def test_cache_dir_follows_xdg_and_falls_back_to_home(
    user_cache: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    assert map_store.cache_dir() == user_cache
    monkeypatch.setenv("XDG_CACHE_HOME", "relative/path")  # not absolute: ignored (XDG spec)
    assert map_store.cache_dir() == Path.home() / ".cache" / map_store.CACHE_FOLDER
    assert sm.DEFAULT_MAP_PATH.parent not in map_store.cache_dir().parents


def test_grid_reaches_above_the_critical_speed_and_the_paper_grid_is_the_packaged_one() -> None:
    new = load_config(NEW_SCREW)
    grid = map_grid.grid_for(new)
    # 1.6 x 4000 rpm is beyond the packaged 6000 rpm: the cell of 4000 rpm is an interior one.
    assert grid.speed_max == map_grid.MapGrid().speed_max
    above = int(np.searchsorted(grid.speeds, new.screw.critical_speed))
    assert above + 1 < grid.speed_nodes
    assert (grid.speed_nodes, grid.temperature_nodes) == (49, 29)
    preview = map_grid.grid_for(new, preview=True)
    nodes = (preview.speed_nodes, preview.temperature_nodes, preview.preload_nodes)
    assert nodes == map_grid.PREVIEW_NODES
    assert preview.speed_max == grid.speed_max
    assert map_grid.grid_for(load_config(None)) == sm.load_map().grid
    slowest = replace(new, screw=replace(new.screw, critical_speed=1.0))  # lowest allowed
    assert map_grid.grid_for(slowest).speed_max == pytest.approx(map_grid.SPEED_REACH)


def test_find_map_refuses_a_table_of_other_parameters_and_says_why(user_cache: Path) -> None:
    new = load_config(NEW_SCREW)
    paper = load_config(None)
    # The packaged table serves the paper screw and is refused for the new one.
    assert map_store.find_map(paper).path == str(sm.DEFAULT_MAP_PATH)
    search = map_store.find_map(new)
    assert search.table is None
    assert len(search.refused) == 1 and "built for other parameters" in search.refused[0]
    # A table of the paper screw passed as a file is refused too, named.
    other = user_cache / "other.npz"
    map_store.save_atomic(_tiny_map(config_fingerprint(paper)), other)
    search = map_store.find_map(new, other)
    assert search.table is None and str(other) in search.refused[0]
    # A missing or corrupt file is named; the table cached under the fingerprint is found.
    assert "no such file" in map_store.find_map(new, user_cache / "none.npz").refused[0]
    corrupt = user_cache / "corrupt.npz"
    corrupt.write_bytes(b"not a map")
    assert "not a readable steady map" in map_store.find_map(new, corrupt).refused[0]
    cached = map_store.cached_map_path(new, map_grid.grid_for(new))
    assert cached.parent == user_cache and config_fingerprint(new)[:20] in cached.name
    map_store.save_atomic(_tiny_map(config_fingerprint(new)), cached)
    found = map_store.find_map(new, other)
    assert found.table is not None and found.path == str(cached)
    assert len(found.refused) == 2  # the file given and the packaged table, each with why
    assert sorted(p.name for p in user_cache.iterdir() if "partial" in p.name) == []


def test_map_command_finds_and_builds_the_preview_table(
    user_cache: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["map", "find", "--config", str(NEW_SCREW)]) == 1
    assert "map build --config" in capsys.readouterr().out
    args = ["map", "build", "--config", str(NEW_SCREW), "--preview", "--workers", "1"]
    assert main(args) == 0
    new = load_config(NEW_SCREW)
    grid = map_grid.grid_for(new, preview=True)
    path = map_store.cached_map_path(new, grid)
    printed = capsys.readouterr()
    assert str(path) in printed.out
    lines = 2 * grid.temperature_nodes * grid.preload_nodes  # one task per sign and node pair
    assert "steady map" in printed.err and f"{lines}/{lines}" in printed.err  # the bar, done
    table = sm.load_map(path)
    assert table.fingerprint == config_fingerprint(new)
    # The preview table agrees with the steady model at one of its own nodes.
    g = table.grid
    op = OperatingPoint(
        screw_speed=float(g.speeds[4]),
        temperature=float(g.temperatures[2]),
        preload=float(g.preloads[6]),
    )
    steady = SteadyStateModel(new, mode="symmetric", tolerance=map_build.MAP_TOLERANCE)
    expected = steady.evaluate(op).drag_torque
    sample = table.sample(op.screw_speed, op.temperature, (op.preload, op.preload), False)
    assert sample.torque.sum() == pytest.approx(expected, rel=1e-6)  # float32 storage
    assert main([*args, "--no-progress"]) == 0
    assert "already built" in capsys.readouterr().out
    assert main(["map", "build", "--config", str(NEW_SCREW), "--workers", "0"]) == 2
    assert "--workers = 0" in capsys.readouterr().err
