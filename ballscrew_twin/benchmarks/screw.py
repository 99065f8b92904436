"""``ballscrew-twin bench screw --config YAML``: a new screw from its YAML to the node at 1 kHz.

Two parts, printed (never asserted):

1. **Time to the node on the screw's own table.** The twin node starts in this process with
   ``config_file: YAML`` and an empty user cache (``--cache``, default a fresh temporary
   folder, so nothing is reused): it serves the preview table, builds the full table in
   ``--workers`` niced processes and switches to it (``ros/tables.py``). Printed: the time from
   before the YAML is read to the node's first tick (preview table), to the full table in use
   and to the first contact states published from it; then the share of ticks on time (within
   1 ms) during the build and over ``--settle`` seconds on the full table; then the same
   ``--settle`` seconds of the paper screw's node on its packaged table, for comparison.
2. **Accuracy of the tables** at ``--points`` random operating points off the nodes (seeded;
   speed log-uniform in [0.1 rpm, the screw's critical speed or the table's highest speed if
   lower], temperature uniform in the table's range, preload uniform in sqrt(preload) over
   [0, 4000] N, so 7 % lie below 20 N; no axial load): the real-time model on the full and on
   the preview table against the symmetric steady model at a 1e-11 scaled
   residual (the model the tables tabulate) on the tables' branch: continued along the speed
   from the table's lowest speed at the point's temperature and preload, as a table line is
   solved (where the steady state is multi-valued, a cold start can land on another branch;
   such points are counted: "cold start elsewhere"). Errors as ``bench accuracy``: drag
   torque relative, contact normal force of the loaded half grooves relative; by preload
   band (0-20, 20-100, >= 100 N), with the points above 1 % counted and those of them colder
   than -10 C apart.
"""

from __future__ import annotations

import argparse
import math
import os
import tempfile
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import SolverError
from ..models.base import OperatingPoint, TwinOutput
from ..models.map_grid import grid_for
from ..models.map_store import cached_map_path, find_map
from ..models.realtime import RealTimeModel
from ..models.steady import SteadyStateModel
from ..models.steady_map import SteadyMap, load_map
from ..params import TwinConfig, load_config
from ..units import RPM
from .accuracy import errors

#: One-line help of this benchmark.
DESCRIPTION = "a new screw: YAML to the node at 1 kHz on its own table; the table's accuracy"
#: Tolerance of the steady reference (scaled residual) [-].
REFERENCE_TOLERANCE = 1e-11
#: Preload bands of the accuracy rows [N] (issue 14: within 1 % at >= 20 N).
PRELOAD_BANDS = ((0.0, 20.0), (20.0, 100.0), (100.0, math.inf))
#: Points colder than this are counted apart among those above 1 % [K] (-10 C).
COLD = 263.15
#: Highest preload of the accuracy points [N] (the table's range).
MAX_PRELOAD = 4000.0
ON_TIME_NS = 1_000_000
#: Longest wait for the table to be built and taken into use [s].
BUILD_TIMEOUT = 1200.0
#: Speeds of the reference's continuation from the table's lowest speed [-].
CONTINUATION_STEPS = 16
#: Relative gap between a cold and a continued solve counted as another branch [-].
BRANCH_GAP = 0.01


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``bench screw``."""
    parser.add_argument("--config", required=True, help="parameter YAML of the screw")
    parser.add_argument(
        "--cache", default="", help="user cache folder (default: a fresh temporary folder)"
    )
    parser.add_argument("--workers", type=int, default=2, help="processes of the table build")
    parser.add_argument("--settle", type=float, default=10.0, help="seconds measured after [s]")
    parser.add_argument("--points", type=int, default=300, help="accuracy points (0: skip)")
    parser.add_argument("--seed", type=int, default=14, help="seed of the accuracy points")
    parser.add_argument("--no-node", action="store_true", help="accuracy only (cache given)")
    parser.add_argument(
        "--no-paper",
        action="store_true",
        help="skip the paper screw's node run (its packaged table) after the new screw's",
    )


def _on_time(latencies: list[int]) -> str:
    if not latencies:
        return "no ticks"
    share = float(np.mean(np.asarray(latencies) <= ON_TIME_NS))
    return f"{share:.2%} of {len(latencies)} ticks on time"


def run_node(config_file: str, workers: int, settle: float) -> dict[str, Any]:
    """Part 1 (see the module docstring); the measured times [s] and on-time shares."""
    import rclpy
    from rclpy.context import Context
    from rclpy.parameter import Parameter

    from ..ros.executors import make_executor, spin
    from ..ros.twin_node import TwinNode

    start = time.monotonic()
    context = Context()
    rclpy.init(context=context)
    overrides = [
        Parameter("config_file", value=config_file),
        Parameter("table_workers", value=workers),
    ]
    node = TwinNode(context=context, parameter_overrides=overrides)
    executor = make_executor("events", context)
    executor.add_node(node)
    node.ticks.latency_log = []
    marks: dict[str, float] = {"constructed": time.monotonic() - start}
    during: list[int] = []

    def table_in_use() -> bool:
        now = time.monotonic() - start
        if "first tick" not in marks and node.ticks.totals.published:
            marks["first tick"] = now
        ready = not (node.tables.preview or node.tables.building)
        if "full table" not in marks and node.ticks.totals.published and ready:
            marks["full table"] = now
            contacts = node.ticks.totals.contacts
            during.extend(node.ticks.latency_log or [])
            node.ticks.latency_log = []
            marks["contacts before"] = contacts
        if "full table" in marks and node.ticks.totals.contacts > marks["contacts before"]:
            marks["first contacts"] = now
            return True
        return now > BUILD_TIMEOUT

    spin(executor, until=table_in_use)
    settle_start = time.monotonic()
    node.ticks.latency_log = []
    spin(executor, until=lambda: time.monotonic() - settle_start > settle)
    after = list(node.ticks.latency_log or [])
    result = {
        "marks": marks,
        "during": _on_time(during),
        "after": _on_time(after),
        "model": node.models.choice.model.name,
        "reason": node.models.choice.reason,
        "table": node.tables.source,
    }
    executor.shutdown()
    node.destroy_node()
    rclpy.try_shutdown(context=context)
    return result


def accuracy_points(
    table: SteadyMap, config: TwinConfig, count: int, seed: int
) -> list[OperatingPoint]:
    """Random operating points over the table's range up to the screw's critical speed (see the
    module docstring)."""
    rng = np.random.default_rng(seed)
    g = table.grid
    top = min(g.speed_max, config.screw.critical_speed)
    speeds = np.exp(rng.uniform(math.log(0.1 * RPM), math.log(top), count))
    speeds *= rng.choice((-1.0, 1.0), count)
    temperatures = rng.uniform(g.temperature_min, g.temperature_max, count)
    preloads = MAX_PRELOAD * rng.uniform(0.0, 1.0, count) ** 2  # as the nodes: 7 % < 20 N
    return [
        OperatingPoint(screw_speed=float(n), temperature=float(t), preload=float(f))
        for n, t, f in zip(speeds, temperatures, preloads, strict=True)
    ]


def continued(model: SteadyStateModel, op: OperatingPoint, speed_min: float) -> TwinOutput:
    """The steady state at ``op`` continued along |speed| from ``speed_min`` [rad/s] (a cold
    start there), warm-started step by step as a table line is solved."""
    model.forget_warm_start()
    magnitude = abs(op.screw_speed)
    if magnitude <= speed_min:
        return model.evaluate(op)
    sign = math.copysign(1.0, op.screw_speed)
    for speed in np.geomspace(speed_min, magnitude, CONTINUATION_STEPS)[:-1]:
        model.evaluate(replace(op, screw_speed=float(sign * speed)))
    return model.evaluate(op)


def run_accuracy(
    config: TwinConfig, tables: dict[str, SteadyMap], count: int, seed: int
) -> list[dict[str, Any]]:
    """Part 2: one row per table and preload band with the error statistics."""
    reference = SteadyStateModel(config, mode="symmetric", tolerance=REFERENCE_TOLERANCE)
    cold = SteadyStateModel(config, mode="symmetric", tolerance=REFERENCE_TOLERANCE)
    models = {name: RealTimeModel(config, steady_map=table) for name, table in tables.items()}
    first = next(iter(tables.values()))
    points = accuracy_points(first, config, count, seed)
    found: dict[str, list[tuple[OperatingPoint, dict[str, float]]]] = {n: [] for n in models}
    failed = elsewhere = 0
    for op in points:
        try:
            ref = continued(reference, op, first.grid.speed_min)
        except SolverError:
            failed += 1
            continue
        cold.forget_warm_start()
        try:
            other = cold.evaluate(op).drag_torque
        except SolverError:
            other = math.nan
        if not abs(other - ref.drag_torque) <= BRANCH_GAP * abs(ref.drag_torque):
            elsewhere += 1
        for name, model in models.items():
            found[name].append((op, errors(model.evaluate(op), ref)))
    rows = []
    for name, results in found.items():
        for low, high in PRELOAD_BANDS:
            chosen = [(op, e) for op, e in results if low <= op.preload < high]
            drag = np.array([e["drag_error"] for _, e in chosen])
            force = np.array([e["force_error"] for _, e in chosen])
            chilly = np.array([op.temperature < COLD for op, _ in chosen], dtype=bool)
            over = drag > 0.01  # NaN (zero reference torque) is not counted
            drag, force = drag[np.isfinite(drag)], force[np.isfinite(force)]
            rows.append(
                {
                    "table": name,
                    "preload": f"[{low:g}, {high:g}) N",
                    "points": len(chosen),
                    "drag_median": float(np.median(drag)) if len(drag) else math.nan,
                    "drag_p95": float(np.percentile(drag, 95)) if len(drag) else math.nan,
                    "drag_max": float(drag.max()) if len(drag) else math.nan,
                    "force_max": float(force.max()) if len(force) else math.nan,
                    "over_1pct": int(np.sum(over)),
                    "over_1pct_cold": int(np.sum(over & chilly)),
                    "reference_failed": failed,
                    "cold_elsewhere": elsewhere,
                }
            )
    return rows


def run(args: argparse.Namespace) -> int:
    """Run both parts and print their numbers."""
    cache = args.cache or tempfile.mkdtemp(prefix="ballscrew_twin_cache_")
    os.environ["XDG_CACHE_HOME"] = str(Path(cache).resolve())
    config = load_config(args.config)
    if not args.no_node:
        result = run_node(args.config, args.workers, args.settle)
        marks = result["marks"]
        print(f"bench screw: {args.config}, cache {cache}, {args.workers} build workers")
        for key in ("constructed", "first tick", "full table", "first contacts"):
            if key in marks:
                print(f"  {key:<15} {marks[key]:7.1f} s after start (before the YAML is read)")
        print(f"  ticks during the build: {result['during']}")
        print(f"  ticks on the full table over {args.settle:g} s: {result['after']}")
        print(f"  model: {result['model']} ({result['reason']}); table {result['table']}")
        if not args.no_paper:
            paper = run_node("", args.workers, args.settle)
            print(f"  paper screw, same run: {paper['after']} over {args.settle:g} s")
    if args.points <= 0:
        return 0
    tables = {}
    found = find_map(config)  # the packaged table of the paper screw, else the cache
    if found.table is not None:
        tables["full"] = found.table
    preview = cached_map_path(config, grid_for(config, preview=True))
    if preview.is_file():
        tables["preview"] = load_map(preview)
    if not tables:
        print(f"no table of {args.config} in {cache}: nothing to measure")
        return 1
    rows = run_accuracy(config, tables, args.points, args.seed)
    print(
        f"accuracy at {args.points} random points off the nodes (seed {args.seed}) against the "
        f"symmetric steady model at {REFERENCE_TOLERANCE:g} continued along the speed; "
        f"{rows[0]['reference_failed']} reference solves failed (left out); a cold start "
        f"lands elsewhere (> {BRANCH_GAP:.0%}) at {rows[0]['cold_elsewhere']} points"
    )
    print(
        "| table | preload | points | drag median | drag p95 | drag max | > 1 % "
        "(of them < -10 C) | force max |"
    )
    print("| --- | --- | --- | --- | --- | --- | --- | --- |")
    for row in rows:
        print(
            f"| {row['table']} | {row['preload']} | {row['points']} | "
            f"{row['drag_median']:.3%} | {row['drag_p95']:.3%} | {row['drag_max']:.3%} | "
            f"{row['over_1pct']} ({row['over_1pct_cold']}) | {row['force_max']:.3%} |"
        )
    return 0
