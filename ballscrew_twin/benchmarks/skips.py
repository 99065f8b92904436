"""``ballscrew-twin bench skips``: measured error bounds of every skip rule and model.

Over the grid preload x speed x temperature (default 0/500/1500/3000 N x 10/100/500/1000/2000/
4000 rpm x -20/20/60 C), turning forwards and backwards, it solves the steady-state model of the
parameter set (warm-started along increasing speed) and measures, at every point, the relative
error (the larger of the two directions) of

- ``symmetric_vertical`` / ``symmetric_horizontal``: one sphere per nut against every sphere
  (full mode), on a vertical and on a horizontal screw;
- ``inertial``: the steady model without centrifugal force and gyroscopic moment against with;
- ``asperity``: without asperity terms (smooth surfaces: Lambda infinite, f(Lambda) = 0)
  against with; the smallest Tallian parameter of the loaded contacts is kept alongside;
- ``catalog_vertical`` / ``catalog_horizontal``: Eq. 52 against the steady model;
- ``realtime``: the real-time model (``models/realtime.py``) at steady state, when installed,

each as ``drag_torque`` (|dT| / |T|), ``nut_torque`` (largest |dT_k| / |T_k| of the two nuts)
and ``contact_force`` (largest |dF_n| over the largest F_n of the reference). Then, unless
``--no-dynamic``, it runs the dynamic model on ``--scenario`` (default
``config/scenarios/steady_check.yaml``) and compares the steady model of the same scene with it
(the bound of skipping the fast sphere dynamics), takes the dynamic reference's own numerical
error (power-balance closure and the drag's fluctuation over the averaging window), and times
one dynamic step of the full parameter set. Costs are CPU times (they rank the models and do
not grow when other programs share the cores). It prints a table and writes the numbers, the
grid, the costs and this command to ``--out`` (default ``config/fidelity_bounds.yaml``).

The transient error of the quasi-static models (their skipping of the fast sphere dynamics
while the commands change) is measured by the accuracy benchmark, not here: pass it with
``--transient-bound`` and ``--transient-source`` and the selection adds it for scenes whose
commands vary (:mod:`ballscrew_twin.fidelity`).
"""

from __future__ import annotations

import argparse
import dataclasses
import datetime
import math
import statistics
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from ..errors import BallscrewTwinError, SolverError
from ..fidelity import bounds_fingerprint
from ..models import registry
from ..models.base import ContactStates, OperatingPoint, TwinOutput
from ..models.steady import SteadyStateModel
from ..params import TwinConfig, check_number, default_config_path, finite, load_config
from ..timing import cpu_time
from ..units import CELSIUS_ZERO, RPM

DESCRIPTION = "measured error bounds of the fidelity skip rules (writes fidelity_bounds.yaml)"
RULES = (
    "symmetric_vertical",
    "symmetric_horizontal",
    "inertial",
    "asperity",
    "catalog_vertical",
    "catalog_horizontal",
    "realtime",
)
METRICS = ("drag_torque", "nut_torque", "contact_force")
REALTIME_STEP = 1e-3  # s, step of the real-time model when measured here
REALTIME_SETTLE_STEPS = 5  # steps at a constant command before its output is compared


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``bench skips``."""
    parser.add_argument("--config", default=None, help="parameter YAML (default: paper screw)")
    parser.add_argument(
        "--preloads", default="0,500,1500,3000", help="grid preloads, comma separated [N]"
    )
    parser.add_argument(
        "--speeds", default="10,100,500,1000,2000,4000", help="grid speeds, comma separated [rpm]"
    )
    parser.add_argument(
        "--temperatures", default="-20,20,60", help="grid temperatures, comma separated [deg C]"
    )
    parser.add_argument("--scenario", default=None, help="dynamic scenario for the reference")
    parser.add_argument("--no-dynamic", action="store_true", help="skip the dynamic reference")
    parser.add_argument(
        "--transient-bound",
        type=float,
        default=None,
        help="relative drag error of quasi-static models in transients, measured elsewhere "
        "(bench accuracy); recorded with --transient-source",
    )
    parser.add_argument("--transient-source", default="", help="command that measured it")
    parser.add_argument("--out", default=None, help="bounds file (default: config/...yaml)")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    parser.add_argument(
        "--show", default=None, help="print the tables of an existing bounds file, measure nothing"
    )


def _floats(text: str, what: str, unit: str) -> list[float]:
    """The sorted distinct numbers [unit] of the comma-separated list ``text`` of ``--what``,
    each by the package's one number check (finite; the refusal names the option, the value
    and the unit)."""
    meta = finite(unit)
    where = f"--{what} {text!r}"
    values = {
        float(check_number(v, meta, where, error=BallscrewTwinError))
        for v in text.split(",")
        if v.strip()
    }
    if not values:
        raise BallscrewTwinError(f"--{what}: {text!r} holds no number")
    return sorted(values)


# --------------------------------------------------------------------------- error metrics


def relative(value: float, reference: float) -> float:
    """|value - reference| / |reference| [-] (0 when both are 0, inf when only the reference)."""
    if reference == 0.0:
        return 0.0 if value == 0.0 else math.inf
    return abs(value - reference) / abs(reference)


def drag_errors(out: TwinOutput, ref: TwinOutput) -> tuple[float, float]:
    """(drag-torque error, largest per-nut torque error) [-]."""
    nut = max(relative(out.nut_torque[k], ref.nut_torque[k]) for k in (0, 1))
    return relative(out.drag_torque, ref.drag_torque), nut


def _force_table(cs: ContactStates) -> dict[tuple[int, int, int], float]:
    """(nut, sphere index within its nut, half groove) -> normal force [N]."""
    first = {k: int(cs.sphere[cs.nut == k].min()) for k in (0, 1) if np.any(cs.nut == k)}
    return {
        (int(n), int(s) - first[int(n)], int(h)): float(f)
        for n, s, h, f in zip(cs.nut, cs.sphere, cs.half_groove, cs.normal_force, strict=True)
    }


def contact_force_error(out: ContactStates, ref: ContactStates) -> float:
    """Largest |F_n - F_n,ref| over the largest reference F_n [-]. A model that solves one
    sphere per nut (symmetric) is compared with every sphere of that nut."""
    got, want = _force_table(out), _force_table(ref)
    scale = max(want.values())
    if scale <= 0.0:
        return 0.0
    worst = 0.0
    for (nut, index, groove), force in want.items():
        key = (nut, index, groove) if (nut, index, groove) in got else (nut, 0, groove)
        worst = max(worst, abs(got[key] - force))
    return worst / scale


def all_errors(out: TwinOutput, ref: TwinOutput) -> list[float]:
    """[drag, nut, contact force] errors [-]; contact force NaN when either has no states."""
    drag, nut = drag_errors(out, ref)
    force = math.nan
    if out.contacts is not None and ref.contacts is not None:
        force = contact_force_error(out.contacts, ref.contacts)
    return [drag, nut, force]


# --------------------------------------------------------------------------- grid


class _Solver:
    """A steady model reused along the grid (warm start), cold retry on failure."""

    def __init__(self, model: SteadyStateModel) -> None:
        self.model = model

    def __call__(self, op: OperatingPoint) -> TwinOutput | None:
        try:
            out = self.model.evaluate(op)
        except SolverError:
            self.model.forget_warm_start()
            try:
                out = self.model.evaluate(op)
            except SolverError:
                self.model.forget_warm_start()
                return None
        return out


def _variants(config: TwinConfig) -> dict[str, _Solver]:
    horizontal = dataclasses.replace(
        config, screw=dataclasses.replace(config.screw, orientation="horizontal")
    )
    vertical = dataclasses.replace(
        config, screw=dataclasses.replace(config.screw, orientation="vertical")
    )
    smooth = dataclasses.replace(
        vertical,
        screw=dataclasses.replace(vertical.screw, ball_roughness=0.0, groove_roughness=0.0),
    )
    return {
        "v_sym": _Solver(SteadyStateModel(vertical, mode="symmetric")),
        "v_full": _Solver(SteadyStateModel(vertical, mode="full")),
        "h_sym": _Solver(SteadyStateModel(horizontal, mode="symmetric")),
        "h_full": _Solver(SteadyStateModel(horizontal, mode="full")),
        "no_inertia": _Solver(SteadyStateModel(vertical, mode="symmetric", inertial_terms=False)),
        "smooth": _Solver(SteadyStateModel(smooth, mode="symmetric")),
    }


def warm_cost(model: SteadyStateModel, repeat: int = 10) -> float:
    """Median CPU time of one warm-started solve [s]: 1500 N / 1000 rpm / 20 C and 1550 N /
    1010 rpm / 21 C solved alternately, each from the other (what a slowly changing scene
    costs per new operating point)."""
    a = OperatingPoint(screw_speed=1000 * RPM, temperature=293.15, preload=1500.0)
    b = OperatingPoint(screw_speed=1010 * RPM, temperature=294.15, preload=1550.0)
    model.evaluate(a)

    def pair() -> None:
        model.evaluate(b)
        model.evaluate(a)

    return cpu_time(pair, repeat) / 2.0


def _merge(forward: list[float], backward: list[float]) -> list[float]:
    """One row from both directions: forward drag, smaller Tallian, larger of each error (NaN
    when either direction was not measured)."""
    merged = [forward[0], min(forward[1], backward[1])]
    for a, b in zip(forward[2:], backward[2:], strict=True):
        merged.append(math.nan if math.isnan(a) or math.isnan(b) else max(a, b))
    return merged


def _realtime(config: TwinConfig) -> Any:
    """The real-time model of the vertical screw, or None (its table was built for other
    parameters: message printed)."""
    vertical = dataclasses.replace(
        config, screw=dataclasses.replace(config.screw, orientation="vertical")
    )
    try:
        return registry.build(registry.ModelName.REALTIME, vertical)
    except BallscrewTwinError as err:
        print(f"real-time model not measured: {err}", file=sys.stderr)
        return None


def measure_grid(
    config: TwinConfig,
    preloads: list[float],
    speeds: list[float],
    temperatures: list[float],
    progress: Callable[[], None] | None = None,
) -> tuple[list[str], list[list[float]], dict[str, float], list[str]]:
    """Error of every rule at every grid point, in both directions of rotation.

    Each speed is solved turning forwards and backwards (a reversal is not a mirror image: the
    slips differ); a row holds the larger error of the two, the smaller Tallian parameter and
    the forward drag torque.

    Args:
        config: parameter set.
        preloads: [N]; speeds: magnitudes [rad/s]; temperatures: [K].
        progress: called once per grid point and direction.

    Returns:
        (columns, rows (NaN: not measured), median warm cost of each model [s], failures).
    """
    columns = ["preload_N", "speed_rad_s", "temperature_K", "drag_torque_Nm", "min_tallian"]
    columns += [f"{rule}.{metric}" for rule in RULES for metric in METRICS]
    solvers = _variants(config)
    catalog = registry.as_evaluating(registry.build(registry.ModelName.CATALOG_ZHOU, config))
    realtime = _realtime(config)
    realtime_times: list[float] = []
    by_point: dict[tuple[float, float, float], list[float]] = {}
    failures: list[str] = []
    nan3 = [math.nan] * 3
    for direction in (1.0, -1.0):
        for temperature in temperatures:
            for preload in preloads:
                for solver in solvers.values():
                    solver.model.forget_warm_start()
                for speed in speeds:
                    op = OperatingPoint(
                        screw_speed=direction * speed, temperature=temperature, preload=preload
                    )
                    outs = {name: solver(op) for name, solver in solvers.items()}
                    for name, out in outs.items():
                        if out is None:
                            failures.append(
                                f"{name}: {preload:g} N, {direction * speed / RPM:g} rpm, "
                                f"{temperature - CELSIUS_ZERO:g} C: no steady state"
                            )
                    base = outs["v_sym"]
                    row = [math.nan, math.nan]
                    if base is not None and base.contacts is not None:
                        cs = base.contacts
                        row = [
                            abs(base.drag_torque),
                            float(np.min(cs.tallian_parameter[cs.in_contact])),
                        ]
                    for name, ref_name in (
                        ("v_sym", "v_full"),
                        ("h_sym", "h_full"),
                        ("no_inertia", "v_sym"),
                        ("smooth", "v_sym"),
                    ):
                        out, ref = outs[name], outs[ref_name]
                        row += nan3 if out is None or ref is None else all_errors(out, ref)
                    cat = catalog.evaluate(op)
                    for ref in (base, outs["h_full"]):
                        row += nan3 if ref is None else [*drag_errors(cat, ref), math.nan]
                    if realtime is not None and base is not None:
                        realtime.reset(op)
                        start = time.process_time()
                        for _ in range(REALTIME_SETTLE_STEPS):
                            rt_out = realtime.step(op, REALTIME_STEP)
                        realtime_times.append((time.process_time() - start) / REALTIME_SETTLE_STEPS)
                        row += all_errors(rt_out, base)
                    else:
                        row += nan3
                    key = (preload, speed, temperature)
                    if key in by_point:
                        row = _merge(by_point[key], row)
                    by_point[key] = row
                    if progress is not None:
                        progress()
    rows = [[*key, *values] for key, values in by_point.items()]
    cost = {
        "catalog": cpu_time(
            lambda: catalog.evaluate(
                OperatingPoint(screw_speed=10.0, temperature=293.15, preload=1500.0)
            ),
            200,
        ),
        "steady_symmetric": warm_cost(solvers["v_sym"].model),
        "steady_full_vertical": warm_cost(solvers["v_full"].model),
        "steady_full_horizontal": warm_cost(solvers["h_full"].model),
    }
    if realtime_times:
        cost["realtime_step"] = statistics.median(realtime_times)
    return columns, rows, cost, failures


# --------------------------------------------------------------------------- dynamic reference


def _display_path(path: Path) -> str:
    """``path`` relative to the project folder when inside it (no machine paths in the file)."""
    root = default_config_path().parent.parent
    try:
        return str(path.resolve().relative_to(root))
    except ValueError:
        return path.name


def measure_dynamic(scenario_path: Path, config: TwinConfig, quiet: bool) -> dict[str, Any]:
    """Steady model against the dynamic model on a scenario, the reference's own numerical
    error, and the cost of one dynamic step of the full parameter set."""
    from ..models.dynamic import DynamicModel
    from ..models.dynamic_loop import StepPlan, TimeLoop
    from ..models.dynamic_state import Commands
    from ..models.scenario import load_scenario
    from ..models.simulation import build_config, simulate

    scenario = load_scenario(scenario_path)
    from tqdm import tqdm

    bar = tqdm(total=1.0, file=sys.stderr, disable=quiet, desc="dynamic reference")

    def advance(fraction: float, _elapsed: float) -> None:
        bar.update(fraction - bar.n)

    try:
        result = simulate(scenario, progress=advance)
    finally:
        bar.close()
    scene_config = build_config(scenario)
    op = OperatingPoint(
        screw_speed=scenario.speed, temperature=scenario.temperature, preload=scenario.preload
    )
    steady = SteadyStateModel(scene_config).evaluate(op)
    s = result.summary
    nuts = s["nut_torque_Nm"]
    window = result.contact_time >= s["window_start_s"] - 1e-12
    forces = result.normal_force[window].mean(axis=0)  # (B, 4)
    assert steady.contacts is not None
    table = _force_table(steady.contacts)
    scale = float(forces.max())
    worst = max(
        abs(float(forces[b, h]) - table[(int(result.ball_nut[b]), 0, h)])
        for b in range(forces.shape[0])
        for h in range(4)
    )
    dyn_drag = s["drag_torque_Nm"]
    numerical = max(abs(s["power_balance_error_relative"]), s["drag_torque_std_Nm"] / abs(dyn_drag))
    # One step of the full parameter set at rest under 1500 N, on the one dynamic loop: each
    # timed call runs the loop's next run step (the state goes on from the last one's end).
    model = DynamicModel(config, 293.15)
    commands = Commands(screw_speed=0.0, preload=1500.0)
    loop = TimeLoop(
        model,
        model.initial_state(commands.preload),
        StepPlan(time_step=model.time_step, implicit_positions=model.implicit_positions),
        lambda _t: commands,
        lambda _step: None,
    )

    def one_step() -> None:
        loop.run(loop.next_step, final_report=False)

    step_cost = cpu_time(one_step, 30, warmup=5)
    return {
        "reference": {
            "drag_torque": relative(steady.drag_torque, dyn_drag),
            "nut_torque": max(
                relative(steady.nut_torque[0], nuts["master"]),
                relative(steady.nut_torque[1], nuts["slave"]),
            ),
            "contact_force": worst / scale,
            "scenario": _display_path(scenario_path),
            "dynamic_drag_torque_Nm": dyn_drag,
            "steady_drag_torque_Nm": steady.drag_torque,
        },
        "dynamic": {
            "drag_torque": numerical,
            "nut_torque": numerical,
            "contact_force": numerical,
            "power_balance_error_relative": abs(s["power_balance_error_relative"]),
            "drag_torque_std_relative": s["drag_torque_std_Nm"] / abs(dyn_drag),
            "step_cost_s": step_cost,
            "time_step_s": scenario.time_step,
            "balls_per_nut": config.screw.balls_per_nut,
        },
    }


# --------------------------------------------------------------------------- report


def _max(columns: list[str], rows: list[list[float]], name: str, mask: Any = None) -> float:
    values = np.array([r[columns.index(name)] for r in rows])
    if mask is not None:
        values = values[mask]
    values = values[np.isfinite(values)]
    return float(values.max()) if len(values) else math.nan


def format_table(columns: list[str], rows: list[list[float]], speeds: list[float]) -> str:
    """Largest error of each rule over the grid, and the speed / Tallian dependence."""
    lines = [f"{'rule':<22}" + "".join(f"{m:>15}" for m in METRICS)]
    for rule in RULES:
        lines.append(
            f"{rule:<22}" + "".join(f"{_max(columns, rows, f'{rule}.{m}'):15.3g}" for m in METRICS)
        )
    speed = np.array([r[1] for r in rows])
    loaded = np.array([r[0] for r in rows]) > 0.0
    lines.append("")
    lines.append(
        "largest drag error by speed, over T and preload (all / preload > 0 only):\n"
        f"  {'speed':>8}  {'no inertia':>21}  {'catalogue (vertical)':>21}  {'real-time':>21}"
    )
    for s in speeds:
        at = np.isclose(speed, s)
        cells = [
            f"{_max(columns, rows, name, at):10.3g} {_max(columns, rows, name, at & loaded):10.3g}"
            for name in (
                "inertial.drag_torque",
                "catalog_vertical.drag_torque",
                "realtime.drag_torque",
            )
        ]
        lines.append(f"  {s / RPM:4.0f} rpm  {cells[0]}  {cells[1]}  {cells[2]}")
    tallian = np.array([r[4] for r in rows])
    lines.append(
        "largest drag error of dropping asperity terms at points with min Lambda >= L "
        "(all / preload > 0 only):"
    )
    name = "asperity.drag_torque"
    for lam in (0.5, 1.0, 1.5, 2.0, 2.26, 3.0):
        above = tallian >= lam
        lines.append(
            f"  L = {lam:4.2f}  {_max(columns, rows, name, above):10.3g} "
            f"{_max(columns, rows, name, above & loaded):10.3g}  ({int(np.sum(above))} points)"
        )
    return "\n".join(lines)


def _clean(value: Any) -> Any:
    """YAML-ready: floats rounded to 7 significant digits, NaN as null."""
    if isinstance(value, float):
        if not math.isfinite(value):
            return None
        return float(f"{value:.7g}")
    if isinstance(value, dict):
        return {k: _clean(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_clean(v) for v in value]
    return value


def run(args: argparse.Namespace) -> int:
    """Measure, print, write the bounds file."""
    from tqdm import tqdm

    if args.show:
        from ..fidelity import load_bounds

        shown = load_bounds(args.show)
        rows = [list(r) for r in shown.rows]
        print(f"{shown.source} ({shown.command}):")
        print(format_table(list(shown.columns), rows, list(shown.grid["speed_rad_s"])))
        return 0
    config = load_config(args.config)
    preloads = _floats(args.preloads, "preloads", "N")
    speeds = [v * RPM for v in _floats(args.speeds, "speeds", "rpm")]
    if min(speeds) <= 0.0:
        raise BallscrewTwinError(f"--speeds {args.speeds}: speed magnitudes must be > 0 rpm")
    temperatures = [v + CELSIUS_ZERO for v in _floats(args.temperatures, "temperatures", "C")]
    out = Path(args.out) if args.out else default_config_path().parent / "fidelity_bounds.yaml"
    command = (
        f"ballscrew-twin bench skips --preloads {args.preloads} --speeds {args.speeds} "
        f"--temperatures {args.temperatures}"
        + (f" --config {args.config}" if args.config else "")
        + (" --no-dynamic" if args.no_dynamic else "")
        + (f" --scenario {args.scenario}" if args.scenario else "")
        + (f" --out {args.out}" if args.out else "")
    )
    transient = args.transient_bound
    if transient is not None:
        if not (math.isfinite(transient) and 0.0 <= transient < 10.0):
            raise BallscrewTwinError(
                f"--transient-bound = {transient}: a relative error in [0, 10)"
            )
        if not args.transient_source:
            raise BallscrewTwinError("--transient-bound needs --transient-source (its command)")
        command += f" --transient-bound {transient} --transient-source '{args.transient_source}'"
    total = len(preloads) * len(speeds) * len(temperatures)
    bar = tqdm(total=2 * total, file=sys.stderr, disable=args.quiet, desc="grid points x 2")
    started = time.perf_counter()
    try:
        columns, rows, cost, failures = measure_grid(
            config, preloads, speeds, temperatures, lambda: bar.update(1)
        )
    finally:
        bar.close()
    grid_time = time.perf_counter() - started
    print(
        f"skip rules over {total} grid points x 2 directions ({grid_time:.1f} s), "
        "largest relative error:"
    )
    print(format_table(columns, rows, speeds))
    print("CPU time per evaluation: " + ", ".join(f"{k} {v * 1e3:.3g} ms" for k, v in cost.items()))
    if failures:
        print(f"{len(failures)} solves without steady state (not measured), e.g. {failures[0]}")
    data: dict[str, Any] = {
        "command": command.strip(),
        "created_utc": datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%dT%H:%M:%SZ"),
        "config": config.name,
        "config_fingerprint": bounds_fingerprint(config),
        "metrics": {
            "drag_torque": "|T - T_ref| / |T_ref|",
            "nut_torque": "max over nuts of |T_k - T_k,ref| / |T_k,ref|",
            "contact_force": "max |F_n - F_n,ref| / max F_n,ref",
        },
        "grid": {
            "preload_N": preloads,
            "speed_rad_s": speeds,
            "temperature_K": temperatures,
        },
        "cost": cost,
        "reference": {"drag_torque": None, "nut_torque": None, "contact_force": None},
        "dynamic": {"drag_torque": None},
        "realtime": None
        if "realtime_step" not in cost
        else {
            "cost_s": cost["realtime_step"],
            "step_s": REALTIME_STEP,
        },
        "failures": failures,
        "columns": columns,
        "rows": rows,
    }
    if not args.no_dynamic:
        scenario = (
            Path(args.scenario)
            if args.scenario
            else default_config_path().parent / "scenarios" / "steady_check.yaml"
        )
        measured = measure_dynamic(scenario, config, args.quiet)
        data.update(measured)
        ref, dyn = measured["reference"], measured["dynamic"]
        if transient is not None:
            ref["transient_drag_torque"] = transient
            ref["transient_source"] = args.transient_source
        print(
            f"steady vs dynamic ({scenario}): drag {ref['drag_torque']:.3g}, nut torque "
            f"{ref['nut_torque']:.3g}, contact force {ref['contact_force']:.3g}; dynamic "
            f"numerical error {dyn['drag_torque']:.3g}, step {dyn['step_cost_s'] * 1e3:.3g} ms CPU "
            f"({config.screw.balls_per_nut} spheres per nut)"
        )
    header = (
        "# Measured error bounds of the fidelity selection (ballscrew_twin/fidelity.py).\n"
        f"# Written by: {data['command']}\n# Do not edit by hand; rerun the command.\n"
    )
    out.write_text(header + yaml.safe_dump(_clean(data), sort_keys=False, width=100))
    print(f"bounds written to {out}")
    return 0
