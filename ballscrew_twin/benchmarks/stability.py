"""``ballscrew-twin bench stability``: every model through adversarial but physical conditions.

Each model is driven through a fixed set of command sequences (cases) at the node's 1 kHz tick,
always through :class:`~ballscrew_twin.models.validity.ValidatedModel`: steps and reversals of
speed (through zero), zero and beyond-range preload, 0-200 N at cold, warm and hot temperature
and low to high speed (the light-preload envelope, where the steady state has several
solutions: docs/model.md, "One branch"), preload steps, speeds up to and beyond the
critical speed, temperatures from -60 to 150 C (the envelope is -40..100 C), axial loads beyond
the envelope, and a long run at a constant command (drift). The dynamic model runs short
scenarios with one sphere per nut (:mod:`~ballscrew_twin.models.simulation`) at the corners of
the envelope and over a sweep of its time step and Jacobian refresh interval.

Reported per model and case: status (``finished``, ``error`` when a solver says it did not
converge, ``nan`` when an output was not finite, ``blow-up`` when a finite drag torque exceeds
the physical bound :func:`torque_bound`, ``exception`` for anything else, ``budget`` when a long
run was stopped at its wall-time budget), ticks done, failed and clamped ticks, the largest
|drag torque| relative to the bound, the drift of a long run, the energy-balance error where
the model has one (steady: work-energy identity of the solution; dynamic: power balance of the
run), the wall time per tick, and the CPU time per tick against the model's own median over
its short cases (a case whose mean is more than :data:`EXPLOSION_FACTOR` times that median is
a run-time explosion).

Printed as a table and written to ``--out`` as ``stability.csv`` and ``stability.md``.
``--quick`` runs a short subset (seconds) used by the CI test. Nothing is asserted here.
"""

from __future__ import annotations

import argparse
import contextlib
import csv
import math
import statistics
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import BallscrewTwinError, NonFiniteOutputError, SolverError
from ..models import registry
from ..models.base import OperatingPoint, TimeSteppingModel, TwinOutput
from ..models.registry import ModelName
from ..models.scenario import Scenario
from ..models.simulation import simulate
from ..models.steady import SteadyStateModel
from ..models.validity import ValidatedModel, ValidityEnvelope, clamp_operating_point
from ..params import TwinConfig, load_config
from ..units import CELSIUS_ZERO, RPM
from .accuracy import LOW_PRELOADS

#: One-line help of this benchmark.
DESCRIPTION = "stability stress test: every model through adversarial but physical commands"

#: Tick of the node [s] (1 kHz).
TICK = 1e-3
#: A case whose mean CPU time per tick exceeds this multiple of the model's median (over its
#: short cases) is a run-time explosion. CPU time of the thread, not wall time: on a shared
#: machine the operating system delays single ticks by milliseconds, whatever the model.
EXPLOSION_FACTOR = 10.0
#: Friction coefficient of the blow-up bound (:func:`torque_bound`) [-]: lubricated steel
#: contacts stay below ~0.1; a friction coefficient of 1 is far beyond any of them.
BLOWUP_FRICTION = 1.0
#: Reference command of the cases: 20 C, 1500 N, 1000 rpm (SI).
BASE = OperatingPoint(screw_speed=1000 * RPM, temperature=20 + CELSIUS_ZERO, preload=1500.0)


def torque_bound(config: TwinConfig, op: OperatingPoint) -> float:
    """Largest physical drag torque at ``op`` [N m]: every axial force through the thread with
    friction coefficient :data:`BLOWUP_FRICTION` at the spheres' outer radius r_m + r_b.

    Forces: the preload, the axial load, the weight of both nuts and the centrifugal force of
    all spheres m Omega^2 r_m (which loads them at zero preload and high speed).
    """
    screw = config.screw
    g = config.environment.gravity
    spheres = 2 * screw.balls_per_nut
    force = (
        op.preload
        + abs(op.axial_load)
        + 2.0 * screw.nut_mass * g
        + spheres * config.ball_mass * op.screw_speed**2 * screw.pitch_radius
    )
    return BLOWUP_FRICTION * force * (screw.pitch_radius + screw.ball_radius)


# ---------------------------------------------------------------------------------------------
# Cases: command sequences, one operating point a tick


def _op(
    rpm: float, celsius: float = 20.0, preload: float = 1500.0, axial: float = 0.0
) -> OperatingPoint:
    return OperatingPoint(
        screw_speed=rpm * RPM,
        temperature=celsius + CELSIUS_ZERO,
        preload=preload,
        axial_load=axial,
    )


def _phases(values: Sequence[OperatingPoint], ticks: int) -> list[OperatingPoint]:
    """``ticks`` commands holding each of ``values`` for an equal share of the ticks."""
    per = max(1, ticks // len(values))
    return [v for v in values for _ in range(per)]


def _ramp(ticks: int, make: Callable[[float], OperatingPoint]) -> list[OperatingPoint]:
    """``make(s)`` for s from 0 to 1 over ``ticks`` (odd count: s = 0.5 is hit exactly)."""
    count = ticks | 1
    return [make(k / (count - 1)) for k in range(count)]


@dataclass(frozen=True)
class Case:
    """A command sequence at :data:`TICK`; ``long`` cases are limited by the long-run budget."""

    name: str
    description: str
    commands: list[OperatingPoint]
    long: bool = False


def cases(config: TwinConfig, ticks: int, long_ticks: int) -> list[Case]:
    """The command sequences of the stress test (``ticks`` per case, ``long_ticks`` for drift)."""
    critical = config.screw.critical_speed / RPM  # rpm
    return [
        Case(
            "speed_steps",
            "0 -> 100 -> 4000 -> 0 rpm steps, 20 C, 1500 N",
            _phases([_op(0.0), _op(100.0), _op(4000.0), _op(0.0)], ticks),
        ),
        Case(
            "speed_reversal_ramp",
            "+1000 -> -1000 rpm linear ramp through exactly 0",
            _ramp(ticks, lambda s: _op(1000.0 * (1.0 - 2.0 * s))),
        ),
        Case(
            "speed_reversal_step",
            "+4000 <-> -4000 rpm abrupt reversals",
            _phases([_op(4000.0), _op(-4000.0), _op(4000.0), _op(-4000.0)], ticks),
        ),
        Case(
            "zero_preload",
            "0 N at 100/1000/4000 rpm and -20/20/60 C",
            _phases(
                [_op(rpm, c, 0.0) for c in (-20.0, 20.0, 60.0) for rpm in (100.0, 1000.0, 4000.0)],
                ticks,
            ),
        ),
        Case(
            "low_preload",
            "0-200 N (12 preloads) at 130/1350/3900 rpm and -20/20/60 C, one point a tick",
            [
                _op(rpm, c, f)
                for c in (-20.0, 20.0, 60.0)
                for rpm in (130.0, 1350.0, 3900.0)
                for f in LOW_PRELOADS
            ],
        ),
        Case(
            "preload_steps",
            "0 -> 3000 -> 0 -> 5000 N steps at 100 rpm",
            _phases([_op(100.0, preload=p) for p in (0.0, 3000.0, 0.0, 5000.0)], ticks),
        ),
        Case(
            "preload_beyond",
            "5000 -> 10000 -> 50000 N (envelope 5000 N) at 1000 rpm",
            _phases([_op(1000.0, preload=p) for p in (5000.0, 1e4, 5e4)], ticks),
        ),
        Case(
            "to_critical_speed",
            f"speed ramp 0 -> 1.2 x critical speed ({1.2 * critical:.0f} rpm), 1500 N",
            _ramp(ticks, lambda s: _op(1.2 * critical * s)),
        ),
        Case(
            "critical_speed_zero_preload",
            "critical speed at 0 and 500 N",
            _phases([_op(critical, preload=0.0), _op(critical, preload=500.0)], ticks),
        ),
        Case(
            "temperatures",
            "-60 .. 150 C ramp at 1000 rpm (envelope -40 .. 100 C)",
            _ramp(ticks, lambda s: _op(1000.0, -60.0 + 210.0 * s)),
        ),
        Case(
            "axial_load",
            "axial load -8000 .. 8000 N ramp (envelope 5000 N), 1500 N preload, 1000 rpm",
            _ramp(ticks, lambda s: _op(1000.0, axial=-8000.0 + 16000.0 * s)),
        ),
        Case(
            "long_run",
            f"{long_ticks} ticks at 1000 rpm, 20 C, 1500 N (drift)",
            [BASE] * long_ticks,
            long=True,
        ),
    ]


# ---------------------------------------------------------------------------------------------
# Models


@dataclass
class CaseResult:
    """Outcome of one model on one case (SI units)."""

    model: str
    case: str
    planned: int
    done: int = 0
    failed: int = 0
    non_finite: int = 0
    blow_ups: int = 0
    clamped: int = 0
    other: int = 0
    first_message: str = ""
    max_torque: float = 0.0
    max_bound_ratio: float = 0.0
    drift: float = math.nan
    energy_balance: float = math.nan
    tick_times: list[float] = field(default_factory=list)  # wall time of each tick [s]
    cpu_times: list[float] = field(default_factory=list)  # CPU time of this thread [s]
    stopped_by_budget: bool = False

    @property
    def status(self) -> str:
        """Worst outcome: nan > blow-up > exception > error > budget > finished."""
        for count, label in (
            (self.non_finite, "nan"),
            (self.blow_ups, "blow-up"),
            (self.other, "exception"),
            (self.failed, "error"),
        ):
            if count:
                return label
        return "budget" if self.stopped_by_budget else "finished"


@dataclass
class Entry:
    """A model under test, driven tick by tick.

    Attributes:
        name: row label.
        model: the model (time-stepping; steady-state models are adapted).
        cold: forget the steady model's warm start before every tick (cold-start robustness).

    A quasi-static steady-state model has an energy balance: its work-energy identity is
    checked at each case's final command (:func:`steady_balance_error`).
    """

    name: str
    model: TimeSteppingModel
    cold: bool = False


#: The models that step, by row label (``(cold)``: the steady model's warm start is forgotten
#: before every tick; the real-time model's label adds its name).
STEPPING_MODELS: tuple[tuple[str, ModelName, bool], ...] = (
    ("catalog-literature", ModelName.CATALOG_LITERATURE, False),
    ("catalog-zhou", ModelName.CATALOG_ZHOU, False),
    ("steady-symmetric (cold)", ModelName.STEADY_SYMMETRIC, True),
    ("steady-full (cold)", ModelName.STEADY_FULL, True),
    ("quasi_static_steady (warm)", ModelName.STEADY, False),
    ("realtime", ModelName.REALTIME, False),
)


def model_registry(config: TwinConfig, quick: bool) -> tuple[list[Entry], list[CaseResult]]:
    """Every model of the package that steps, built by the registry (``quick``: without the
    cold steady solves), and one ``exception`` row for each model that could not be built
    (e.g. the real-time model without a table for ``config``)."""
    entries: list[Entry] = []
    unavailable: list[CaseResult] = []
    for label, name, cold in STEPPING_MODELS:
        if quick and cold:
            continue
        try:
            model = registry.as_stepping(registry.build(name, config))
        except BallscrewTwinError as err:
            failed = CaseResult(model=label, case="(construction)", planned=0, other=1)
            failed.first_message = str(err)
            unavailable.append(failed)
            continue
        if name is ModelName.REALTIME:
            label = f"{label} ({model.name})"
        entries.append(Entry(label, model, cold=cold))
    return entries, unavailable


def steady_balance_error(model: SteadyStateModel, op: OperatingPoint) -> float:
    """Relative work-energy error of ``model``'s solution at ``op`` [-] (warm-started from
    where the model is).

    The moment of the spheres on the screw, less the torque that lifts nuts and spheres and the
    torque of the external axial load's work (F_a p / (2 pi)), equals the dissipated power over
    the speed (docs/model.md section 7); the error is relative to the largest of these torques.
    NaN at standstill, where no power flows and the identity says nothing.
    """
    if op.screw_speed == 0.0:
        return math.nan
    solution = model.solve(op)
    load_torque = op.axial_load * model.config.screw.lead / (2.0 * math.pi)
    drag = solution.output.drag_torque
    residual = solution.screw_torque_direct - solution.gravity_torque - load_torque - drag
    scale = max(abs(solution.gravity_torque), abs(load_torque), abs(drag))
    return abs(residual) / scale


# ---------------------------------------------------------------------------------------------
# Running


def _note(result: CaseResult, message: str) -> None:
    if not result.first_message:
        result.first_message = message


def run_case(
    entry: Entry,
    case: Case,
    config: TwinConfig,
    envelope: ValidityEnvelope,
    long_budget: float,
) -> CaseResult:
    """Drive ``entry`` through ``case``; never raises for a failing tick."""
    model = ValidatedModel(entry.model, envelope)
    steady = getattr(entry.model, "model", None)
    result = CaseResult(model=entry.name, case=case.name, planned=len(case.commands))
    first_torque: float | None = None
    started = time.perf_counter()
    try:
        model.reset(case.commands[0])
    except BallscrewTwinError as err:
        _note(result, f"reset: {err}")
    for op in case.commands:
        if case.long and time.perf_counter() - started > long_budget:
            result.stopped_by_budget = True
            break
        if entry.cold and isinstance(steady, SteadyStateModel):
            steady.forget_warm_start()
        tick, cpu = time.perf_counter(), time.thread_time()
        out: TwinOutput | None = None
        try:
            out = model.step(op, TICK)
        except NonFiniteOutputError as err:
            result.non_finite += 1
            _note(result, str(err))
        except SolverError as err:
            result.failed += 1
            _note(result, str(err))
        except Exception as err:  # a stress test reports every failure, it does not stop
            result.other += 1
            _note(result, f"{type(err).__name__}: {err}")
        result.tick_times.append(time.perf_counter() - tick)
        result.cpu_times.append(time.thread_time() - cpu)
        result.done += 1
        if out is None:
            continue
        if clamp_operating_point(op, envelope)[1]:  # not the real-time table's accuracy notes
            result.clamped += 1
        torque = abs(out.drag_torque)
        ratio = torque / torque_bound(config, out.operating_point)
        result.max_torque = max(result.max_torque, torque)
        result.max_bound_ratio = max(result.max_bound_ratio, ratio)
        if ratio > 1.0:
            result.blow_ups += 1
            _note(result, f"|drag torque| {torque:.4g} N m is {ratio:.3g} x the bound")
        if case.long:
            if first_torque is None:
                first_torque = out.drag_torque
            elif first_torque != 0.0:
                change = abs(out.drag_torque - first_torque) / abs(first_torque)
                result.drift = max(0.0 if math.isnan(result.drift) else result.drift, change)
    if isinstance(steady, SteadyStateModel):
        final, _ = clamp_operating_point(case.commands[-1], envelope)
        try:
            result.energy_balance = steady_balance_error(steady, final)
        except SolverError as err:
            _note(result, f"energy balance: {err}")
    return result


# ------------------------------------------------------------------ dynamic model


@dataclass(frozen=True)
class DynamicCase:
    """A short dynamic-model run with one sphere per nut (SI)."""

    name: str
    description: str
    op: OperatingPoint
    time_step: float = 1e-6
    jacobian_interval: int = 1


def dynamic_cases(quick: bool) -> list[DynamicCase]:
    """Corners of the envelope and a sweep of step size and Jacobian refresh interval.

    Preloads are per-sphere equivalents of the 25-sphere nut (1500 N x 1/25 = 60 N).
    """
    base = _op(100.0, preload=60.0)
    if quick:
        return [DynamicCase("dt_1us", "100 rpm, 20 C, 60 N, dt 1 us", base)]
    return [
        DynamicCase("dt_0.5us", "100 rpm, 20 C, 60 N, dt 0.5 us", base, time_step=5e-7),
        DynamicCase("dt_1us", "100 rpm, 20 C, 60 N, dt 1 us", base),
        DynamicCase("dt_2us", "100 rpm, 20 C, 60 N, dt 2 us", base, time_step=2e-6),
        DynamicCase("jacobian_10", "dt 1 us, Jacobian every 10 steps", base, jacobian_interval=10),
        DynamicCase("cold_-40C", "-40 C", replace(base, temperature=-40 + CELSIUS_ZERO)),
        DynamicCase("hot_100C", "100 C", replace(base, temperature=100 + CELSIUS_ZERO)),
        DynamicCase("zero_preload", "0 N", replace(base, preload=0.0)),
        DynamicCase("reverse_4000rpm", "-4000 rpm", replace(base, screw_speed=-4000 * RPM)),
        DynamicCase("beyond_200C", "200 C (clamped to 100 C)", replace(base, temperature=473.15)),
    ]


def _scenario(case: DynamicCase, op: OperatingPoint, duration: float) -> Scenario:
    """The paper's protocol compressed into ``duration`` [s]: preload over the first 1/12,
    speed from 1/12 to 1/3, averaged over the last third."""
    return Scenario(
        name=f"stability_{case.name}",
        balls_per_nut=1,
        temperature=op.temperature,
        preload=op.preload,
        preload_ramp_end=duration / 12.0,
        speed=op.screw_speed,
        speed_ramp_start=duration / 12.0,
        speed_ramp_end=duration / 3.0,
        duration=duration,
        average_window=duration / 3.0,
        time_step=case.time_step,
        jacobian_interval=case.jacobian_interval,
        output_interval=duration / 20.0,
        contact_output_interval=duration / 2.0,
    )


def run_dynamic_case(
    case: DynamicCase, config: TwinConfig, envelope: ValidityEnvelope, duration: float
) -> CaseResult:
    """One short run of the dynamic model (operating point clamped into the envelope)."""
    op, warnings = clamp_operating_point(case.op, envelope)
    sc = _scenario(case, op, duration)
    result = CaseResult(model="dynamic (1 sphere/nut)", case=case.name, planned=sc.steps)
    result.clamped = sc.steps if warnings else 0
    if warnings:
        _note(result, warnings[0])
    cpu = time.thread_time()
    try:
        run = simulate(sc)
    except SolverError as err:
        result.non_finite = 1 if "diverged" in str(err) else 0
        result.failed = 0 if result.non_finite else 1
        result.first_message = str(err)
        return result
    except Exception as err:  # a stress test reports every failure, it does not stop
        result.other = 1
        result.first_message = f"{type(err).__name__}: {err}"
        return result
    s = run.summary
    result.done = s["steps"]
    drag = float(s["drag_torque_Nm"])
    # The spheres' torque on the screw less the gravity torque, after the ramps: the motor
    # torque would also include the torque accelerating the screw's inertia.
    settled = run.time >= s["window_start_s"] - 0.5 * sc.time_step
    contact_drag = -(run.screw_torque + run.gravity_torque)[settled]
    result.max_torque = float(np.max(np.abs(contact_drag)))
    result.max_bound_ratio = result.max_torque / torque_bound(config, op)
    result.energy_balance = abs(float(s["power_balance_error_relative"]))
    result.tick_times = [float(s["step_cost_s"])]
    result.cpu_times = [(time.thread_time() - cpu) / max(sc.steps, 1)]
    if result.max_bound_ratio > 1.0:
        result.blow_ups = 1
    if s["unconverged_steps"]:
        _note(result, f"{s['unconverged_steps']} steps not converged; drag {drag:.4g} N m")
    elif not result.first_message:
        result.first_message = f"drag {drag:.4g} N m (averaged over the last third)"
    return result


# ---------------------------------------------------------------------------------------------
# Report

COLUMNS = (
    "model",
    "case",
    "status",
    "ticks",
    "failed",
    "clamped",
    "max_abs_torque_Nm",
    "max_torque_over_bound",
    "drift_rel",
    "energy_balance_rel",
    "mean_tick_s",
    "max_tick_s",
    "mean_cpu_over_median",
    "runtime_explosion",
    "first_message",
)


def rows_of(results: Sequence[CaseResult], medians: dict[str, float]) -> list[dict[str, Any]]:
    """Report rows (SI); the mean CPU time of a tick is compared with the model's own median
    (``medians``: CPU seconds per tick by model name)."""
    rows = []
    for r in results:
        times = r.tick_times
        median = medians.get(r.model, math.nan)
        ratio = statistics.fmean(r.cpu_times) / median if r.cpu_times and median > 0 else math.nan
        rows.append(
            {
                "model": r.model,
                "case": r.case,
                "status": r.status,
                "ticks": f"{r.done}/{r.planned}",
                "failed": r.failed + r.non_finite + r.other,
                "clamped": r.clamped,
                "max_abs_torque_Nm": r.max_torque,
                "max_torque_over_bound": r.max_bound_ratio,
                "drift_rel": r.drift,
                "energy_balance_rel": r.energy_balance,
                "mean_tick_s": statistics.fmean(times) if times else math.nan,
                "max_tick_s": max(times) if times else math.nan,
                "mean_cpu_over_median": ratio,
                "runtime_explosion": "yes" if ratio > EXPLOSION_FACTOR else "no",
                "first_message": r.first_message,
            }
        )
    return rows


def _fmt(value: Any) -> str:
    if isinstance(value, float):
        return "-" if math.isnan(value) else f"{value:.3g}"
    return str(value)


def markdown_table(rows: Sequence[dict[str, Any]]) -> str:
    """The rows as a markdown table (messages cut to 90 characters)."""
    lines = ["| " + " | ".join(COLUMNS) + " |", "|" + "---|" * len(COLUMNS)]
    for row in rows:
        cells = [_fmt(row[c]) for c in COLUMNS]
        cells[-1] = cells[-1][:90].replace("|", "/")
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def case_legend(case_list: Sequence[Case], dyn: Sequence[DynamicCase]) -> str:
    """Markdown list of the cases and what they command."""
    lines = [f"- `{c.name}`: {c.description}" for c in case_list]
    lines += [f"- dynamic `{d.name}`: {d.description}" for d in dyn]
    return "\n".join(lines)


def write_report(rows: Sequence[dict[str, Any]], out: Path, header: str, legend: str) -> None:
    """``stability.csv`` (full precision) and ``stability.md`` (header, table, case legend)
    in ``out``."""
    out.mkdir(parents=True, exist_ok=True)
    with (out / "stability.csv").open("w", newline="", encoding="utf-8") as handle:
        writer = csv.DictWriter(handle, fieldnames=COLUMNS)
        writer.writeheader()
        writer.writerows(rows)
    (out / "stability.md").write_text(
        f"{header}\n\n{markdown_table(rows)}\n\nCases:\n\n{legend}\n", encoding="utf-8"
    )


@dataclass(frozen=True)
class Settings:
    """Sizes of a stress-test run."""

    ticks: int
    long_ticks: int
    long_budget: float  # s of wall time per long run
    dynamic_duration: float  # s of simulated time per dynamic case
    quick: bool


QUICK = Settings(ticks=6, long_ticks=2000, long_budget=1.0, dynamic_duration=1.2e-4, quick=True)


def run_stability(
    config: TwinConfig, settings: Settings, progress: bool = False
) -> list[dict[str, Any]]:
    """Run every model through every case; the report rows (see :data:`COLUMNS`)."""
    from tqdm import tqdm

    envelope = ValidityEnvelope.for_config(config)
    entries, unavailable = model_registry(config, settings.quick)
    case_list = cases(config, settings.ticks, settings.long_ticks)
    dyn = dynamic_cases(settings.quick)
    results: list[CaseResult] = list(unavailable)
    with tqdm(
        total=len(entries) * len(case_list) + len(dyn), desc="stability", disable=not progress
    ) as bar:
        for entry in entries:
            # untimed warm-up (the first call loads the compiled kernels); a failure here is
            # reported by the cases
            with contextlib.suppress(Exception):
                ValidatedModel(entry.model, envelope).step(BASE, TICK)
            for case in case_list:
                bar.set_postfix_str(f"{entry.name}: {case.name}")
                results.append(run_case(entry, case, config, envelope, settings.long_budget))
                bar.update()
        for dcase in dyn:
            bar.set_postfix_str(f"dynamic: {dcase.name}")
            results.append(run_dynamic_case(dcase, config, envelope, settings.dynamic_duration))
            bar.update()
    short = {c.name for c in case_list if not c.long}
    medians = {
        e.name: statistics.median(
            [t for r in results if r.model == e.name and r.case in short for t in r.cpu_times]
        )
        for e in entries
    }
    dynamic_costs = [t for r in results if r.model.startswith("dynamic") for t in r.cpu_times]
    if dynamic_costs:
        medians["dynamic (1 sphere/nut)"] = statistics.median(dynamic_costs)
    return rows_of(results, medians)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``bench stability``."""
    parser.add_argument("--config", default=None, help="parameter YAML (default: paper screw)")
    parser.add_argument("--out", default="out/stability", help="folder for the CSV and markdown")
    parser.add_argument("--quick", action="store_true", help="the short CI subset (seconds)")
    parser.add_argument("--ticks", type=int, default=40, help="ticks per case (1 kHz)")
    parser.add_argument("--long-ticks", type=int, default=100_000, help="ticks of the long run")
    parser.add_argument(
        "--long-budget", type=float, default=150.0, help="wall seconds per long run and model"
    )
    parser.add_argument(
        "--dynamic-duration", type=float, default=3e-3, help="simulated s per dynamic case"
    )
    parser.add_argument("--quiet", action="store_true", help="no progress bar")


def run(args: argparse.Namespace) -> int:
    """Run, print the table, write CSV and markdown."""
    config = load_config(args.config)
    settings = (
        QUICK
        if args.quick
        else Settings(
            ticks=args.ticks,
            long_ticks=args.long_ticks,
            long_budget=args.long_budget,
            dynamic_duration=args.dynamic_duration,
            quick=False,
        )
    )
    started = time.perf_counter()
    rows = run_stability(config, settings, progress=not args.quiet)
    wall = time.perf_counter() - started
    header = (
        f"Stability stress test ({'quick' if settings.quick else 'full'}): {settings.ticks} ticks "
        f"per case at {TICK * 1e3:g} ms, long run {settings.long_ticks} ticks (budget "
        f"{settings.long_budget:g} s), dynamic cases {settings.dynamic_duration * 1e3:g} ms; "
        f"parameter set {config.source}; wall time {wall:.1f} s"
    )
    print(header)
    print(markdown_table(rows))
    legend = case_legend(
        cases(config, settings.ticks, settings.long_ticks), dynamic_cases(settings.quick)
    )
    write_report(rows, Path(args.out), header, legend)
    print(f"wrote {Path(args.out) / 'stability.csv'} and {Path(args.out) / 'stability.md'}")
    return 0
