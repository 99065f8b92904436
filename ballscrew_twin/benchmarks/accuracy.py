"""``ballscrew-twin bench accuracy``: run time against error of every model (work-precision).

Three parts, each against a converged high-fidelity reference:

1. **Steady points** (preload x speed x temperature, off the map's nodes): every steady-capable
   model (catalogue formulas, steady model symmetric and full, real-time map at two
   resolutions) against the steady model in full mode at a tight tolerance. The dynamic model
   agrees with that steady reference to -0.39 % at steady state (issue 4, docs/model.md). Run
   time is per evaluation, warm-started from the previous point as in use.
2. **Transients** at the node's 1 kHz tick (speed ramp, reversal through zero, temperature
   drift, preload step, preload loss as a fault): every time-stepping model against the
   quasi-static reference (the same steady reference solved at every tick). The dynamic model
   cannot run these seconds-long scenes (about an hour of wall time per simulated second), so
   its gap to the quasi-static answer is measured separately in part 3. Run time is per
   simulated second.
3. **Dynamic check** (skipped with ``--quick`` or ``--no-dynamic``): a 10 ms run of the
   dynamic model with 3 spheres per nut (1 ms speed ramp to 300 rpm), against the quasi-static
   steady model of the same screw evaluated at the dynamic model's screw speed at each sample:
   the error of the quasi-static assumption itself, sample by sample and averaged over the
   last 5 ms.

Errors: drag torque |T - T_ref| / |T_ref|; per-nut torque max_k |T_k - T_k,ref| / |T_ref|;
contact normal force and Tallian parameter: largest relative error over the loaded half
grooves of the nut means (what the node publishes per sphere; on a vertical screw all spheres
of a nut are alike); contact angle: largest absolute error of the loaded contacts [deg].
In transients the relative errors are taken where |speed| >= 10 rpm (the drag torque passes
through zero in a reversal); the peak absolute error over all ticks is reported too.

Outputs in ``--out``: ``accuracy_points.csv`` (every steady point and model),
``accuracy_summary.csv`` (one row per part, scene and model), ``accuracy.png`` (log-log run
time against error per model) and ``accuracy.md`` (the table for docs/benchmarks.md).
"""

from __future__ import annotations

import argparse
import csv
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import MapError, SolverError
from ..models import registry
from ..models.base import OperatingPoint, QuasiStaticModel, TwinOutput
from ..models.registry import ModelName, ModelOptions
from ..models.steady import SteadyStateModel
from ..models.steady_map import SteadyMap, load_map
from ..params import TwinConfig, load_config
from ..units import CELSIUS_ZERO, RPM

#: One-line help of this benchmark.
DESCRIPTION = "work-precision: run time against error of every model (CSV, PNG, markdown)"

#: Scaled-residual tolerance of the steady reference (full mode); 1e-10 is the model default.
REFERENCE_TOLERANCE = 1e-11
#: Speeds below this are left out of the relative transient errors [rad/s].
RELATIVE_ERROR_MIN_SPEED = 10.0 * RPM
#: Node tick of the transient scenes [s].
TICK = 1e-3

#: Steady grid: preloads [N] and speeds [rpm] between the map's nodes; the issue's
#: temperatures -20/20/60 C (map nodes in temperature) and three mid-cell ones [C].
PRELOADS = (0.0, 180.0, 720.0, 1650.0, 2900.0)
SPEEDS_RPM = (130.0, 470.0, 1350.0, 2600.0, 3900.0)
TEMPERATURES_C = (-20.0, 20.0, 60.0, -17.5, 22.5, 57.5)
QUICK_POINTS = ((470.0, 22.5, 720.0), (2600.0, -17.5, 1650.0), (130.0, 57.5, 180.0))
#: Low-preload grid (issue 14, item 4): preloads [N] from 0 to 200 N at the steady grid's speeds
#: and temperatures; the real-time model against the symmetric steady model solved cold.
LOW_PRELOADS = (0.0, 2.0, 5.0, 10.0, 15.0, 20.0, 30.0, 50.0, 75.0, 100.0, 150.0, 200.0)
#: Preload bands [N) of the low-preload summary (the issue's goals: 1 % from 20 N up).
LOW_PRELOAD_BANDS = ((0.0, 20.0), (20.0, 100.0), (100.0, 201.0))


@dataclass(frozen=True)
class Scene:
    """A transient scene: commands as functions of time [s] (SI: rad/s, K, N)."""

    name: str
    duration: float
    speed: Callable[[float], float]
    temperature: Callable[[float], float]
    preload: Callable[[float], float]

    def command(self, t: float) -> OperatingPoint:
        """The operating point commanded at ``t`` [s]."""
        return OperatingPoint(
            screw_speed=self.speed(t), temperature=self.temperature(t), preload=self.preload(t)
        )


def _ramp(t: float, t0: float, t1: float, a: float, b: float) -> float:
    """a before t0, b after t1, linear between."""
    return a + (b - a) * min(max((t - t0) / (t1 - t0), 0.0), 1.0)


def _const(value: float) -> Callable[[float], float]:
    return lambda t: value


def scenes(quick: bool) -> list[Scene]:
    """The fixed transient scenes (shortened to a few ticks with ``quick``)."""
    c = CELSIUS_ZERO
    full = [
        Scene(
            "speed ramp 100->4000 rpm in 1 s, 20 C, 1500 N",
            1.2,
            lambda t: _ramp(t, 0.1, 1.1, 100 * RPM, 4000 * RPM),
            _const(20 + c),
            _const(1500.0),
        ),
        Scene(
            "reversal +500->-500 rpm in 0.2 s, 20 C, 1500 N",
            0.4,
            lambda t: _ramp(t, 0.1, 0.3, 500 * RPM, -500 * RPM),
            _const(20 + c),
            _const(1500.0),
        ),
        Scene(
            "temperature drift 20->60 C in 1 s, 1000 rpm, 1500 N",
            1.0,
            _const(1000 * RPM),
            lambda t: _ramp(t, 0.0, 1.0, 20 + c, 60 + c),
            _const(1500.0),
        ),
        Scene(
            "preload step 500->2500 N in 10 ms, 1000 rpm, 20 C",
            0.3,
            _const(1000 * RPM),
            _const(20 + c),
            lambda t: _ramp(t, 0.1, 0.11, 500.0, 2500.0),
        ),
        Scene(
            "fault: preload loss 2000->150 N in 2 ms, 1500 rpm, 40 C",
            0.3,
            _const(1500 * RPM),
            _const(40 + c),
            lambda t: _ramp(t, 0.1, 0.102, 2000.0, 150.0),
        ),
    ]
    if quick:
        return [
            Scene(
                "reversal +50->-50 rpm in 20 ms, 20 C, 1500 N",
                0.02,
                lambda t: _ramp(t, 0.0, 0.02, 50 * RPM, -50 * RPM),
                _const(20 + c),
                _const(1500.0),
            )
        ]
    return full


def steady_points(quick: bool) -> list[OperatingPoint]:
    """The steady grid (three points with ``quick``)."""
    triples = (
        QUICK_POINTS
        if quick
        else [(n, t, f) for t in TEMPERATURES_C for f in PRELOADS for n in SPEEDS_RPM]
    )
    return [
        OperatingPoint(screw_speed=n * RPM, temperature=t + CELSIUS_ZERO, preload=f)
        for n, t, f in triples
    ]


def half_resolution(table: SteadyMap) -> SteadyMap | None:
    """The map with every other node of each axis (a cheaper map, same build), or None when
    the map is too small to halve."""
    grid = table.grid.coarse()
    try:
        grid.check_buildable()
    except MapError:
        return None
    return SteadyMap(
        grid=grid,
        torque=table.torque[:, ::2, ::2, ::2],
        contacts=table.contacts[:, ::2, ::2, ::2],
        static=table.static[::2, ::2],
        filled=table.filled[:, ::2, ::2, ::2],
        fingerprint=table.fingerprint,
        orientation=table.orientation,
    )


class _Reference:
    """Steady model, full mode, tight tolerance; falls back to the default tolerance."""

    def __init__(self, config: TwinConfig) -> None:
        self.tight = SteadyStateModel(config, mode="full", tolerance=REFERENCE_TOLERANCE)
        self.default = SteadyStateModel(config, mode="full")
        self.fallbacks = 0
        self.name = "reference"

    def evaluate(self, op: OperatingPoint) -> TwinOutput:
        try:
            return self.tight.evaluate(op)
        except SolverError:
            self.fallbacks += 1
            return self.default.evaluate(op)


# ---------------------------------------------------------------------------------------------
# Errors


def _nut_means(out: TwinOutput, field: str) -> np.ndarray:
    """(2, 4) mean of a contact field over each nut's spheres."""
    assert out.contacts is not None
    values = np.asarray(getattr(out.contacts, field), dtype=np.float64)
    nut, half = out.contacts.nut, out.contacts.half_groove
    return np.array([[values[(nut == k) & (half == h)].mean() for h in range(4)] for k in range(2)])


def errors(out: TwinOutput, ref: TwinOutput) -> dict[str, float]:
    """Errors of ``out`` against ``ref`` (see the module docstring); NaN where not resolved."""
    scale = abs(ref.drag_torque)
    result = {
        "drag_error": abs(out.drag_torque - ref.drag_torque) / scale if scale > 0 else math.nan,
        "drag_abs_error": abs(out.drag_torque - ref.drag_torque),
        "nut_error": math.nan,
        "force_error": math.nan,
        "angle_error_deg": math.nan,
        "tallian_error": math.nan,
    }
    if out.contacts is None or ref.contacts is None:
        return result
    if scale > 0:
        result["nut_error"] = float(
            np.max(np.abs(np.subtract(out.nut_torque, ref.nut_torque))) / scale
        )
    loaded = _nut_means(ref, "in_contact") > 0.5
    if not loaded.any():
        return result

    def relative(field: str) -> float:
        a, b = _nut_means(out, field)[loaded], _nut_means(ref, field)[loaded]
        return float(np.max(np.abs(a - b) / np.maximum(np.abs(b), 1e-300)))

    result["force_error"] = relative("normal_force")
    result["tallian_error"] = relative("tallian_parameter")
    angle = _nut_means(out, "contact_angle")[loaded] - _nut_means(ref, "contact_angle")[loaded]
    result["angle_error_deg"] = float(np.degrees(np.max(np.abs(angle))))
    return result


# ---------------------------------------------------------------------------------------------
# Parts


Row = dict[str, Any]


def _map_models(config: TwinConfig, table: SteadyMap) -> list[tuple[str, Any]]:
    """The real-time model on the map and on its half-resolution version."""
    tables = [("realtime-map", table), ("realtime-map-half", half_resolution(table))]
    return [
        (label, registry.build(ModelName.REALTIME, config, ModelOptions(table=half_or_full)))
        for label, half_or_full in tables
        if half_or_full is not None
    ]


def _steady_models(config: TwinConfig, table: SteadyMap, quick: bool) -> list[tuple[str, Any]]:
    """Every steady-capable model (``quick``: without the full-mode steady model, which costs
    as much as the reference)."""
    names = [ModelName.CATALOG_LITERATURE, ModelName.CATALOG_ZHOU, ModelName.STEADY_SYMMETRIC]
    names += [] if quick else [ModelName.STEADY_FULL]
    return [(str(name), registry.build(name, config)) for name in names] + _map_models(
        config, table
    )


def run_steady(
    config: TwinConfig, table: SteadyMap, quick: bool, progress: bool
) -> tuple[list[Row], list[Row]]:
    """Part 1: per-point rows and per-model summary rows."""
    from tqdm import tqdm

    points = steady_points(quick)
    reference = _Reference(config)
    started = time.perf_counter()
    refs = [reference.evaluate(op) for op in tqdm(points, desc="reference", disable=not progress)]
    ref_time = (time.perf_counter() - started) / len(points)
    point_rows: list[Row] = []
    summary: list[Row] = [
        _summary_row(
            "steady",
            "steady grid",
            f"reference (steady-full, tol {REFERENCE_TOLERANCE:g})",
            ref_time,
            "s/evaluation",
            [],
        )
    ]
    for name, model in tqdm(
        _steady_models(config, table, quick), desc="models", disable=not progress
    ):
        model.evaluate(points[0])  # compile / warm up
        outs, elapsed = [], 0.0
        for op in points:
            start = time.perf_counter()
            outs.append(model.evaluate(op))
            elapsed += time.perf_counter() - start
        errs = [errors(out, ref) for out, ref in zip(outs, refs, strict=True)]
        for op, out, ref, err in zip(points, outs, refs, errs, strict=True):
            point_rows.append(
                {
                    "model": name,
                    "speed_rpm": op.screw_speed / RPM,
                    "temperature_C": op.temperature - CELSIUS_ZERO,
                    "preload_N": op.preload,
                    "drag_torque_Nm": out.drag_torque,
                    "reference_Nm": ref.drag_torque,
                    **err,
                }
            )
        summary.append(
            _summary_row("steady", "steady grid", name, elapsed / len(points), "s/evaluation", errs)
        )
        if any(op.preload == 0.0 for op in points):
            loaded = [e for e, op in zip(errs, points, strict=True) if op.preload > 0.0]
            summary.append(
                _summary_row(
                    "steady",
                    "steady grid, preload > 0",
                    name,
                    elapsed / len(points),
                    "s/evaluation",
                    loaded,
                )
            )
    if reference.fallbacks:
        summary[0]["note"] = f"{reference.fallbacks} points at tolerance 1e-10 (tight one failed)"
    return point_rows, summary


def run_low_preload(
    config: TwinConfig, table: SteadyMap, quick: bool, progress: bool
) -> tuple[list[Row], list[Row]]:
    """Part 1b: the real-time model at 0-200 N against the symmetric steady model, each point
    solved cold (the model's branch where it has several: the start-up state, docs/model.md
    "One branch") at the reference tolerance; per-point rows and one summary row per preload
    band, its note naming the worst point and the points the steady model could not solve."""
    from tqdm import tqdm

    preloads = LOW_PRELOADS[::4] if quick else LOW_PRELOADS
    points = [
        OperatingPoint(screw_speed=n * RPM, temperature=t + CELSIUS_ZERO, preload=f)
        for t in (TEMPERATURES_C[:1] if quick else TEMPERATURES_C)
        for f in preloads
        for n in (SPEEDS_RPM[:2] if quick else SPEEDS_RPM)
    ]
    reference = SteadyStateModel(config, mode="symmetric", tolerance=REFERENCE_TOLERANCE)
    model = registry.as_evaluating(
        registry.build(ModelName.REALTIME, config, ModelOptions(table=table))
    )
    point_rows: list[Row] = []
    results: list[tuple[OperatingPoint, dict[str, float]]] = []
    failed: list[OperatingPoint] = []
    elapsed = 0.0
    for op in tqdm(points, desc="low preload", disable=not progress):
        reference.forget_warm_start()
        try:
            ref = reference.evaluate(op)
        except SolverError:
            failed.append(op)
            continue
        start = time.perf_counter()
        out = model.evaluate(op)
        elapsed += time.perf_counter() - start
        err = errors(out, ref)
        results.append((op, err))
        point_rows.append(
            {
                "model": "realtime-map (low preload)",
                "speed_rpm": op.screw_speed / RPM,
                "temperature_C": op.temperature - CELSIUS_ZERO,
                "preload_N": op.preload,
                "drag_torque_Nm": out.drag_torque,
                "reference_Nm": ref.drag_torque,
                **err,
            }
        )
    summary = []
    for low, high in LOW_PRELOAD_BANDS:
        band = [(op, e) for op, e in results if low <= op.preload < high]
        row = _summary_row(
            "low preload",
            f"{low:g}-{min(high, 200.0):g} N (cold steady reference)",
            "realtime-map",
            elapsed / max(len(results), 1),
            "s/evaluation",
            [e for _, e in band],
        )
        notes = []
        if band:
            op, e = max(band, key=lambda item: item[1]["drag_error"])
            notes.append(
                f"worst {100 * e['drag_error']:.3g} % at {op.screw_speed / RPM:.0f} rpm, "
                f"{op.temperature - CELSIUS_ZERO:.1f} C, {op.preload:g} N; "
                f"{sum(1 for _, x in band if x['drag_error'] > 0.01)} of {len(band)} above 1 %"
            )
        lost = [op for op in failed if low <= op.preload < high]
        if lost:
            notes.append(f"{len(lost)} points the cold steady solve did not converge at")
        row["note"] = "; ".join(notes)
        summary.append(row)
    return point_rows, summary


def _summary_row(
    part: str, scene: str, model: str, seconds: float, unit: str, errs: Sequence[dict[str, float]]
) -> Row:
    def worst(key: str) -> float:
        values = [e[key] for e in errs if not math.isnan(e[key])]
        return max(values) if values else math.nan

    drag = [e["drag_error"] for e in errs if not math.isnan(e["drag_error"])]
    return {
        "part": part,
        "scene": scene,
        "model": model,
        "run_time_s": seconds,
        "run_time_unit": unit,
        "drag_error_max": max(drag) if drag else math.nan,
        "drag_error_median": float(np.median(drag)) if drag else math.nan,
        "drag_abs_error_max_Nm": worst("drag_abs_error"),
        "nut_error_max": worst("nut_error"),
        "force_error_max": worst("force_error"),
        "angle_error_max_deg": worst("angle_error_deg"),
        "tallian_error_max": worst("tallian_error"),
        "note": "",
    }


def run_transients(config: TwinConfig, table: SteadyMap, quick: bool, progress: bool) -> list[Row]:
    """Part 2: every time-stepping model through every scene at 1 kHz."""
    from tqdm import tqdm

    rows: list[Row] = []
    for scene in scenes(quick):
        ticks = round(scene.duration / TICK)
        commands = [scene.command(k * TICK) for k in range(1, ticks + 1)]
        reference = QuasiStaticModel(_Reference(config))
        start = time.perf_counter()
        refs = [
            reference.step(op, TICK)
            for op in tqdm(commands, desc=f"reference: {scene.name}", disable=not progress)
        ]
        ref_time = (time.perf_counter() - start) / scene.duration
        rows.append(
            _summary_row(
                "transient",
                scene.name,
                "reference (quasi-static steady-full)",
                ref_time,
                "s/simulated s",
                [],
            )
        )
        models: list[tuple[str, Any]] = [
            *(
                (f"quasi-static {name}", registry.as_stepping(registry.build(name, config)))
                for name in (ModelName.CATALOG_ZHOU, ModelName.STEADY_SYMMETRIC)
            ),
            *_map_models(config, table),
        ]
        for name, model in models:
            model.reset(commands[0])
            model.step(commands[0], TICK)  # warm up
            model.reset(commands[0])
            outs, elapsed = [], 0.0
            for op in commands:
                t0 = time.perf_counter()
                outs.append(model.step(op, TICK))
                elapsed += time.perf_counter() - t0
            errs = [errors(o, r) for o, r in zip(outs, refs, strict=True)]
            moving = [
                e
                for e, op in zip(errs, commands, strict=True)
                if abs(op.screw_speed) >= RELATIVE_ERROR_MIN_SPEED
            ]
            row = _summary_row(
                "transient", scene.name, name, elapsed / scene.duration, "s/simulated s", moving
            )
            row["drag_abs_error_max_Nm"] = max(e["drag_abs_error"] for e in errs)
            rows.append(row)
    return rows


def run_dynamic(progress: bool) -> list[Row]:
    """Part 3: the dynamic model against the quasi-static steady model during a speed ramp."""
    from ..models.scenario import scenario_from_mapping
    from ..models.simulation import MECHANISMS, build_config, simulate

    scenario = scenario_from_mapping(
        {
            "name": "accuracy_dynamic_ramp",
            "balls_per_nut": 3,
            "temperature": 20 + CELSIUS_ZERO,
            "preload": 180.0,  # N: 1500 N x 3/25, the paper's load per sphere
            "preload_ramp_end": 2.5e-5,
            "speed": 300 * RPM,
            "speed_ramp_start": 2.5e-4,
            "speed_ramp_end": 1.25e-3,
            "duration": 1.0e-2,
            "average_window": 5.0e-3,
            "time_step": 1e-6,
            "jacobian_interval": 1,
            "output_interval": 2.5e-5,
            "contact_output_interval": 1e-3,
        },
        source="bench accuracy",
    )
    from tqdm import tqdm

    bar = tqdm(total=1000, desc="dynamic ramp", disable=not progress)

    def report(fraction: float, _elapsed: float) -> None:
        bar.update(int(fraction * 1000) - bar.n)

    start = time.perf_counter()
    result = simulate(scenario, progress=report)
    bar.close()
    wall = time.perf_counter() - start
    config = build_config(scenario)
    steady = registry.as_evaluating(registry.build(ModelName.STEADY_FULL, config))
    # The steady drag is the mechanisms' dissipation / speed; normal damping is zero there.
    mechanisms = [k for k, name in enumerate(MECHANISMS) if name != "normal_damping"]
    dissipation = result.mechanism_dissipation[:, mechanisms].sum(axis=1)
    moving = np.abs(result.screw_speed) >= RELATIVE_ERROR_MIN_SPEED
    sample_errors = []
    for speed, power in zip(result.screw_speed[moving], dissipation[moving], strict=True):
        op = OperatingPoint(
            screw_speed=float(speed), temperature=scenario.temperature, preload=scenario.preload
        )
        dynamic_drag = power / speed
        sample_errors.append(
            abs(steady.evaluate(op).drag_torque - dynamic_drag) / abs(dynamic_drag)
        )
    window = result.time >= scenario.duration - scenario.average_window
    mean_speed = float(result.screw_speed[window].mean())
    window_drag = float(dissipation[window].mean()) / mean_speed
    op = OperatingPoint(
        screw_speed=mean_speed, temperature=scenario.temperature, preload=scenario.preload
    )
    window_error = (steady.evaluate(op).drag_torque - window_drag) / window_drag
    row = _summary_row(
        "dynamic",
        "speed ramp 0->300 rpm in 1 ms, 3 spheres/nut, 20 C, 180 N",
        "quasi-static steady-full vs dynamic",
        wall / scenario.duration,
        "s/simulated s",
        [],
    )
    row["drag_error_max"] = max(sample_errors)
    row["drag_error_median"] = float(np.median(sample_errors))
    row["note"] = (
        "drag = dissipation of the friction mechanisms / screw speed, sampled every 25 us "
        f"where |speed| >= 10 rpm; mean over the last {scenario.average_window * 1e3:g} ms: "
        f"quasi-static {100 * window_error:+.2g} % off the dynamic model "
        f"({result.summary.get('unconverged_steps', 0)} unconverged dynamic steps); run time is "
        "the dynamic model's"
    )
    return [row]


# ---------------------------------------------------------------------------------------------
# Outputs


def _write_csv(path: Path, rows: list[Row]) -> None:
    with path.open("w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)


def _plot(path: Path, summary: list[Row]) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(12, 5))
    # Steady panel: filled markers for preload > 0, crosses for the whole grid with 0 N.
    panels = (
        ("steady", ("steady grid, preload > 0", "steady grid"), "s per evaluation"),
        ("transient", None, "s per simulated s"),
    )
    for ax, (part, scenes_, xlabel) in zip(axes, panels, strict=True):
        rows = [r for r in summary if r["part"] == part]
        models = sorted({r["model"] for r in rows if not math.isnan(r["drag_error_max"])})
        for index, model in enumerate(models):
            color = f"C{index}"
            mine = [r for r in rows if r["model"] == model]
            for scene, marker in zip(scenes_ or (None,), ("o", "x"), strict=False):
                chosen = [r for r in mine if scene is None or r["scene"] == scene]
                x = [r["run_time_s"] for r in chosen]
                y = [max(r["drag_error_max"], 1e-8) for r in chosen]
                label = model if marker == "o" else f"{model} (incl. 0 N)"
                ax.loglog(x, y, marker, color=color, label=label if chosen else None)
        for r in rows:
            if r["model"].startswith("reference"):
                ax.axvline(r["run_time_s"], color="grey", linestyle=":", linewidth=0.8)
        ax.axhline(0.01 if part == "steady" else 0.05, color="red", linestyle="--", linewidth=0.8)
        ax.set_xlabel(f"run time [{xlabel}] (dotted: reference)")
        ax.set_ylabel("max drag-torque error [-] (1e-8 = exact)")
        ax.set_title(
            "steady grid" if part == "steady" else "transient scenes (one point per scene)"
        )
        ax.legend(fontsize=7)
        ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def _fmt(value: float, percent: bool = False) -> str:
    if isinstance(value, float) and math.isnan(value):
        return "-"
    return f"{100 * value:.3g} %" if percent else f"{value:.3g}"


def _markdown(summary: list[Row], command: str) -> str:
    lines = [
        f"Command: `{command}`",
        "",
        "| part | scene | model | run time | drag err max | drag err median | nut err max "
        "| force err max | angle err max [deg] | Tallian err max |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for r in summary:
        unit = "s/eval" if r["run_time_unit"] == "s/evaluation" else "s/sim s"
        lines.append(
            f"| {r['part']} | {r['scene']} | {r['model']} | {_fmt(r['run_time_s'])} {unit} "
            f"| {_fmt(r['drag_error_max'], True)} | {_fmt(r['drag_error_median'], True)} "
            f"| {_fmt(r['nut_error_max'], True)} | {_fmt(r['force_error_max'], True)} "
            f"| {_fmt(r['angle_error_max_deg'])} | {_fmt(r['tallian_error_max'], True)} |"
        )
    notes = [f"- {r['model']} ({r['scene']}): {r['note']}" for r in summary if r["note"]]
    return "\n".join(lines + (["", *notes] if notes else [])) + "\n"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``bench accuracy``."""
    parser.add_argument("--config", default=None, help="parameter YAML (default: paper screw)")
    parser.add_argument("--map", default=None, help="steady map .npz (default: the committed one)")
    parser.add_argument("--out", default="bench_accuracy", help="output directory")
    parser.add_argument("--quick", action="store_true", help="a few points and ticks (CI smoke)")
    parser.add_argument("--no-dynamic", action="store_true", help="skip the dynamic-model check")
    parser.add_argument(
        "--low-preload-only",
        action="store_true",
        help="run only the low-preload part (0-200 N, real-time model against cold steady solves)",
    )
    parser.add_argument("--no-progress", action="store_true", help="no progress bars")


def run(args: argparse.Namespace) -> int:
    """Run the parts, write the outputs, print the table."""
    config = load_config(args.config)
    table = load_map(args.map)
    progress = not args.no_progress
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    point_rows, summary = run_low_preload(config, table, args.quick, progress)
    if not args.low_preload_only:
        steady_rows, steady_summary = run_steady(config, table, args.quick, progress)
        point_rows, summary = steady_rows + point_rows, steady_summary + summary
        summary += run_transients(config, table, args.quick, progress)
    if not (args.quick or args.no_dynamic or args.low_preload_only):
        summary += run_dynamic(progress)
    _write_csv(out / "accuracy_points.csv", point_rows)
    _write_csv(out / "accuracy_summary.csv", summary)
    _plot(out / "accuracy.png", summary)
    command = "ballscrew-twin bench accuracy" + (" --quick" if args.quick else "")
    command += " --low-preload-only" if args.low_preload_only else ""
    text = _markdown(summary, command)
    (out / "accuracy.md").write_text(text)
    print(text)
    print(f"wrote {out}/accuracy_points.csv, accuracy_summary.csv, accuracy.png, accuracy.md")
    return 0
