"""The twin node's real-time table of a screw without one: refused tables named, a preview
served at once, the full table built on a thread and handed over, progress on /diagnostics."""

from __future__ import annotations

import signal
import time
from dataclasses import replace
from pathlib import Path

import pytest
from rclpy.executors import SingleThreadedExecutor

from ballscrew_twin.models import map_grid, map_store
from ballscrew_twin.models import steady_map as sm
from ballscrew_twin.models.base import OperatingPoint
from ballscrew_twin.params import config_fingerprint, load_config
from ballscrew_twin.ros import diagnostics, fidelity_modes
from ballscrew_twin.ros.tables import RealTimeTables

from .conftest import SpinUntil
from .test_twin_node import _twin

NEW_SCREW = Path(__file__).resolve().parents[2] / "config" / "screw_32x10.yaml"


@pytest.fixture(autouse=True)
def small_grids(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A user cache of this test alone and tables of a few nodes (built in about a second)."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    original = map_grid.grid_for

    def small(config: object, preview: bool = False) -> map_grid.MapGrid:
        grid = original(config, preview)  # type: ignore[arg-type]
        nodes = 5 if preview else 7
        return replace(grid, speed_nodes=nodes, temperature_nodes=5, preload_nodes=nodes)

    monkeypatch.setattr(map_grid, "grid_for", small)


def test_a_new_screw_gets_a_preview_then_its_own_table() -> None:
    config = load_config(NEW_SCREW)
    lines: list[str] = []
    handler = signal.getsignal(signal.SIGINT)
    tables = RealTimeTables(config, "", workers=1, log=lines.append)
    assert tables.table is not None and tables.preview  # serves from the start
    # The preview is built in this process: its Ctrl-C handler (the node's) must stay.
    assert signal.getsignal(signal.SIGINT) is handler
    assert tables.table.fingerprint == config_fingerprint(config)
    assert any("refused" in line and "other parameters" in line for line in lines)
    first = tables.check()
    assert first.level == diagnostics.WARN
    deadline = time.monotonic() + 120.0
    built = None
    while built is None and time.monotonic() < deadline:
        built = tables.take_built()
        time.sleep(0.05)
    assert built is not None, lines
    assert not tables.preview and tables.table is built.table
    assert (
        built.path == map_store.cached_map_path(config, map_grid.grid_for(config))
        and built.path.is_file()
    )
    assert any("100%" in line for line in lines)  # progress on the console
    check = tables.check()
    assert check.level == diagnostics.OK and str(built.path) in check.message
    assert dict(check.values)["refused 1"].endswith(f"has {config_fingerprint(config)[:12]})")
    # The real-time model runs on it with per-sphere states; the next start finds it cached.
    settings = fidelity_modes.ModelSettings(config=config, table=tables.table)
    choice = fidelity_modes.choose("auto", settings)
    assert choice.mode == "realtime"
    op = OperatingPoint(screw_speed=50.0, temperature=300.0, preload=800.0)
    out = choice.model.step(op, 1e-3)
    assert out.contacts is not None and len(out.contacts.sphere) == 2 * 36 * 4
    again = RealTimeTables(config, "", workers=1, log=lines.append)
    assert not again.building and not again.preview and again.source == str(built.path)


def test_without_workers_nothing_is_built_and_auto_says_why() -> None:
    config = load_config(NEW_SCREW)
    tables = RealTimeTables(config, "", workers=0, log=lambda _line: None)
    assert tables.table is None and not tables.building
    check = tables.check()
    assert check.level == diagnostics.WARN and "map build --config" in check.message
    choice = fidelity_modes.choose("auto", fidelity_modes.ModelSettings(config=config))
    assert choice.mode == "catalog"
    assert "built for other parameters" in choice.reason and "map build" in choice.reason


def test_a_table_of_other_parameters_is_never_used(tmp_path: Path) -> None:
    """The paper screw's packaged table given as realtime_map for the new screw: refused
    (named on /diagnostics); the explicit realtime fidelity cannot be built with it."""
    config = load_config(NEW_SCREW)
    tables = RealTimeTables(config, str(sm.DEFAULT_MAP_PATH), 0, lambda _line: None)
    assert tables.table is None
    assert str(sm.DEFAULT_MAP_PATH) in dict(tables.check().values)["refused 1"]
    settings = fidelity_modes.ModelSettings(config=config, realtime_map=str(sm.DEFAULT_MAP_PATH))
    with pytest.raises(ValueError, match="built for other parameters"):
        fidelity_modes.choose("realtime", settings)


def test_stop_cancels_a_running_build() -> None:
    config = load_config(NEW_SCREW)
    tables = RealTimeTables(config, "", workers=1, log=lambda _line: None)
    tables.stop(timeout=60.0)
    assert not tables.building
    assert tables.take_built() is None or tables.table is not None


def test_the_node_on_a_new_screw_switches_to_its_built_table(
    executor: SingleThreadedExecutor, spin_until: SpinUntil
) -> None:
    """twin_node with the new screw's YAML: per-sphere states from the preview at once, the
    built table taken into use, the real-time table check on /diagnostics at each stage."""
    twin = _twin(executor, config_file=str(NEW_SCREW), table_workers=1)
    assert twin.models.choice.mode == "realtime" and twin.tables.preview
    names = {c.name: c for c in twin.diagnostic_checks()}
    assert names["real-time table"].level == diagnostics.WARN
    assert spin_until(executor, lambda: not twin.tables.preview, timeout=120.0)
    assert (
        twin.models.choice.mode == "realtime"
        and "table of this screw built" in twin.models.choice.reason
    )
    assert twin.models.switches == 1
    check = {c.name: c for c in twin.diagnostic_checks()}["real-time table"]
    assert check.level == diagnostics.OK and "built for this screw" in check.message
    count = twin.ticks.totals.contacts
    assert spin_until(executor, lambda: twin.ticks.totals.contacts > count)
    assert twin.last_output is not None and twin.last_output.fidelity == "realtime-map"


def test_the_node_names_a_refused_table_and_never_uses_it(
    executor: SingleThreadedExecutor,
) -> None:
    """The paper screw's table given for the new screw, no build: the catalogue serves (the
    only model left) and /diagnostics names the file refused and why."""
    twin = _twin(
        executor,
        config_file=str(NEW_SCREW),
        realtime_map=str(sm.DEFAULT_MAP_PATH),
        table_workers=0,
    )
    assert twin.models.choice.mode == "catalog"
    check = {c.name: c for c in twin.diagnostic_checks()}["real-time table"]
    assert check.level == diagnostics.WARN
    refused = dict(check.values)["refused 1"]
    assert str(sm.DEFAULT_MAP_PATH) in refused and "built for other parameters" in refused
