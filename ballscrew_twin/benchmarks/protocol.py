"""``ballscrew-twin bench protocol``: cost of the paper protocol on the dynamic model, printed.

Runs a scenario (default: ``config/scenarios/protocol_short.yaml``, the paper's protocol with
the full 2 x 25-sphere model shortened to 12 ms) on one core and prints

- wall time per simulated second, separately for the transient (until the speed ramp ends) and
  the hold (after it), and per step;
- the projected wall time of the paper protocol (0.6 s: 0.1 s of ramps, 0.5 s of hold) from
  those two rates, and with ``--full`` the actual wall time of ``paper_protocol.yaml``;
- where the time goes: contact-law evaluations, Jacobians and Newton iterations per step, and
  the share of the compiled step in the wall time (cProfile);
- with ``--convergence DT1,DT2,...``: the averaged drag torque of the scenario at each time
  step, its difference to the finest one and the observed order;
- with ``--corners``: a time-compressed protocol (:func:`corner_scenario`) at every corner of
  the envelope (preload 0 / 1500 / 3000 N, 100 / 4000 rpm, -20 / 20 / 60 C) with, per corner,
  whether it finished, non-finite values, blow-up against physical bounds (:data:`BLOWUP`),
  the smallest film thickness, unconverged steps, power-balance error, averaged drag torque and
  wall / CPU time; a table printed and, with ``--out DIR``, written as ``corners.csv`` and
  ``corners.md``.

It measures; it never asserts a speed. Times in s, torques in N m (printed also in N mm).
"""

from __future__ import annotations

import argparse
import cProfile
import csv
import math
import os
import pstats
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import BallscrewTwinError
from ..models.scenario import Scenario, load_scenario
from ..models.simulation import simulate
from ..models.simulation_result import SimulationResult
from ..units import CELSIUS_ZERO, RPM

#: One-line help of this benchmark.
DESCRIPTION = "cost of the paper protocol on the dynamic model (and its time-step convergence)"

SCENARIO_DIR = Path(__file__).resolve().parents[2] / "config" / "scenarios"
PAPER_TRANSIENT = 0.1  # s, end of the paper's speed ramp
PAPER_DURATION = 0.6  # s, the paper's protocol
NMM_PER_NM = 1e3

#: Figures of earlier runs (docs/benchmarks.md), printed beside a run of the same scenario and
#: duration: (scenario name, duration [s]) -> (date, time step [s] of the semi-implicit step
#: they used, CPU time [s], contact-law evaluations per step, unconverged steps, drag torque
#: [N m], power-balance error [-], load average).
PREVIOUS = {
    ("paper_protocol", 0.6): ("2026-11-26", 2e-6, 103.1, 2.51, 0, 18.5251e-3, -0.0027, 1.7),
    ("protocol_short", 0.012): ("2026-11-26", 2e-6, 20.6, 11.58, 410, 18.5325e-3, -0.021, 4.0),
}

#: The corner runs with implicit sphere positions: this step [s], after the start phase (the
#: preload ramp and the standstill, until the speed ramp) at CORNER_TIME_STEP semi-implicit.
CORNER_IMPLICIT_STEP = 1e-5

#: The envelope of issue 4: preloads [N], speeds [rpm], temperatures [deg C] (CLI units).
CORNER_PRELOADS = (0.0, 1500.0, 3000.0)
CORNER_SPEEDS_RPM = (100.0, 4000.0)
CORNER_TEMPERATURES_C = (-20.0, 20.0, 60.0)

#: Time-compressed protocol of the corner runs [s]: the paper's 5 ms preload ramp, a standstill,
#: a speed ramp, a hold; averages over the last CORNER_WINDOW.
CORNER_PRELOAD_RAMP = 5e-3
CORNER_SPEED_RAMP = (6e-3, 12e-3)
CORNER_DURATION = 20e-3
CORNER_WINDOW = 5e-3
CORNER_OUTPUT = 1e-4  # s, sampling of the series and of the contact states
CORNER_TIME_STEP = 2e-6  # s, the converged step of paper_protocol.yaml (unless --time-step)

#: Blow-up bounds (physical, generous): the screw speed may overshoot its command by the PI
#: controller's transient, never double it; a nut or contact force never exceeds twice the
#: preload plus the largest inertial / gravity term of this screw (well under 500 N).
BLOWUP = {
    "speed_factor": 2.0,
    "speed_margin_rad_s": 1.0,
    "force_factor": 2.0,
    "force_margin_N": 500.0,
}


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``bench protocol``."""
    parser.add_argument(
        "--scenario",
        default=str(SCENARIO_DIR / "protocol_short.yaml"),
        help="scenario YAML (default: config/scenarios/protocol_short.yaml)",
    )
    parser.add_argument(
        "--spheres", type=int, default=None, help="loaded spheres in all (two nuts), even"
    )
    parser.add_argument("--duration", type=float, default=None, help="simulated time [s]")
    parser.add_argument("--time-step", type=float, default=None, help="integration step [s]")
    parser.add_argument(
        "--average-window", type=float, default=None, help="averaging window at the end [s]"
    )
    parser.add_argument(
        "--convergence",
        default=None,
        help="comma-separated time steps [s]: drag torque of the scenario at each",
    )
    parser.add_argument(
        "--full", action="store_true", help="also run config/scenarios/paper_protocol.yaml"
    )
    parser.add_argument(
        "--corners",
        action="store_true",
        help="run a 20 ms protocol at every corner of the envelope (preload 0/1500/3000 N, "
        "100/4000 rpm, -20/20/60 C) and tabulate its health",
    )
    parser.add_argument(
        "--out", default=None, help="folder for corners.csv and corners.md (with --corners)"
    )
    parser.add_argument(
        "--implicit-positions",
        action="store_true",
        help="sphere and screw positions implicit (backward Euler; steps above ~3 us)",
    )
    parser.add_argument(
        "--fine-time-step", type=float, default=None, help="step of the start phase [s]"
    )
    parser.add_argument(
        "--fine-until", type=float, default=None, help="end of the start phase [s] (0: none)"
    )
    parser.add_argument(
        "--semi-implicit",
        action="store_true",
        help="the semi-implicit step throughout (the integrator before issue 16, round 4), at "
        "--time-step or the scenario's fine_time_step",
    )
    parser.add_argument(
        "--baseline",
        type=float,
        default=None,
        help="also run the scenario semi-implicit at this step [s] and print the two side by side",
    )
    parser.add_argument(
        "--reference",
        type=float,
        default=None,
        help="also run it semi-implicit at this step [s] (e.g. 1e-6): drag and balance of every "
        "run against it, side by side",
    )
    parser.add_argument(
        "--scaling",
        default=None,
        help="comma-separated spheres per nut (e.g. 5,10,25): CPU time per simulated second "
        "of the scenario at each, against the number of spheres",
    )


def _scenario(args: argparse.Namespace) -> Scenario:
    """The chosen scenario with the command-line overrides (validated again)."""
    scenario = load_scenario(args.scenario)
    changes: dict[str, Any] = {}
    if args.spheres is not None:
        if args.spheres < 2 or args.spheres % 2:
            raise BallscrewTwinError(f"--spheres = {args.spheres}: an even number >= 2 is needed")
        changes["balls_per_nut"] = args.spheres // 2
    if args.duration is not None:
        changes["duration"] = args.duration
    if args.time_step is not None:
        changes["time_step"] = args.time_step
    if args.average_window is not None:
        changes["average_window"] = args.average_window
    if args.implicit_positions:
        changes["implicit_positions"] = True
    if args.fine_time_step is not None:
        changes["fine_time_step"] = args.fine_time_step
    if args.fine_until is not None:
        changes["fine_until"] = args.fine_until
    scenario = replace(scenario, **changes) if changes else scenario
    if args.semi_implicit:
        step = args.time_step or scenario.fine_time_step or scenario.time_step
        scenario = semi_implicit(scenario, step)
    return scenario


def semi_implicit(scenario: Scenario, time_step: float) -> Scenario:
    """``scenario`` with the semi-implicit step of ``time_step`` [s] throughout (no start
    phase, positions explicit in the contact actions)."""
    return replace(
        scenario,
        time_step=time_step,
        implicit_positions=False,
        fine_time_step=None,
        fine_until=0.0,
    )


def integrator_label(scenario: Scenario) -> str:
    """How ``scenario`` integrates, in words (steps in us)."""
    step = f"dt = {scenario.time_step * 1e6:g} us"
    if scenario.implicit_positions:
        label = f"implicit sphere and screw positions, {step}"
    else:
        label = f"semi-implicit, {step}"
    if scenario.substeps > 1 and scenario.fine_time_step is not None:
        label += (
            f" ({scenario.fine_time_step * 1e6:g} us semi-implicit until "
            f"{scenario.fine_until * 1e3:g} ms)"
        )
    return label


def _timed_run(scenario: Scenario) -> tuple[SimulationResult, float, float, float, float]:
    """Run ``scenario``; wall and CPU time [s] of this process spent before and after the end
    of the speed ramp (CPU time is what one core would take without other load)."""
    split = min(scenario.speed_ramp_end / scenario.duration, 1.0)
    marks: list[tuple[float, float, float]] = []
    cpu0 = time.process_time()

    def progress(fraction: float, elapsed: float) -> None:
        marks.append((fraction, elapsed, time.process_time() - cpu0))

    result = simulate(scenario, progress=progress)
    wall = float(result.summary["wall_time_s"])
    cpu = time.process_time() - cpu0
    # Times at the last progress mark before the split (marks every 0.5 % of the run).
    before = [m for m in marks if m[0] <= split]
    wall_before = before[-1][1] if before else 0.0
    cpu_before = before[-1][2] if before else 0.0
    return result, wall_before, wall - wall_before, cpu_before, cpu - cpu_before


def _run_once(scenario: Scenario) -> dict[str, Any]:
    """Cost of one run with its profile summary, printed; returns its figures (CPU time [s],
    contact-law evaluations per step, unconverged steps (all, listed in the hold), drag torque
    [N m], power-balance error [-])."""
    profile = cProfile.Profile()
    profile.enable()
    result, transient_wall, hold_wall, transient_cpu, hold_cpu = _timed_run(scenario)
    profile.disable()
    s = result.summary
    wall = float(s["wall_time_s"])
    cpu = transient_cpu + hold_cpu
    ramp_end = min(scenario.speed_ramp_end, scenario.duration)
    hold = scenario.duration - ramp_end
    spheres = 2 * int(s["balls_per_nut"])
    print(
        f"scenario {scenario.name}: {spheres} spheres, {integrator_label(scenario)}, "
        f"{scenario.duration:g} s simulated, {s['steps']} steps; one core (pid {os.getpid()}, "
        f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores)",
        flush=True,
    )
    print(
        f"  wall time {wall:.1f} s, CPU time {cpu:.1f} s, "
        f"{s['step_cost_s'] * 1e3:.3f} ms/step wall (profiled)"
    )
    print(
        f"  per simulated second: wall {wall / scenario.duration:.1f} s, "
        f"CPU {cpu / scenario.duration:.1f} s"
    )
    for label, transient_time, hold_time in (
        ("wall", transient_wall, hold_wall),
        ("CPU", transient_cpu, hold_cpu),
    ):
        rate_transient = transient_time / ramp_end if ramp_end > 0 else math.nan
        rate_hold = hold_time / hold if hold > 0 else math.nan
        print(
            f"    {label}: transient (0 .. {ramp_end:g} s) {rate_transient:.1f} s/s; "
            f"hold ({ramp_end:g} .. {scenario.duration:g} s) {rate_hold:.1f} s/s"
        )
        if math.isfinite(rate_hold) and math.isfinite(rate_transient):
            projected = rate_transient * PAPER_TRANSIENT + rate_hold * (
                PAPER_DURATION - PAPER_TRANSIENT
            )
            print(
                f"    projected paper protocol ({PAPER_DURATION} s, {spheres} spheres, this "
                f"step), {label}: {projected:.0f} s = {projected / 60:.1f} min (target: 60 s)"
            )
    work = s.get("work_per_step", {})
    print(
        "  per step: {:.2f} contact-law evaluations, {:.3f} Jacobians, {:.2f} Newton "
        "iterations; {} steps not converged".format(
            work.get("contact_evaluations", math.nan),
            work.get("jacobians", math.nan),
            work.get("newton_iterations", math.nan),
            s.get("unconverged_steps", 0),
        )
        + f"; {s.get('fallback_steps', 0)} steps redone as semi-implicit substeps"
    )
    listed = s.get("unconverged", {}).get("listed", [])
    in_hold = sum(entry["time_s"] >= ramp_end for entry in listed)
    if listed:
        times = ", ".join(f"{entry['time_s']:.6g}" for entry in listed[:10])
        print(f"    not converged at t = {times} s ({in_hold} of these after {ramp_end:g} s)")
    stats = pstats.Stats(profile)
    raw = stats.stats  # type: ignore[attr-defined]
    kernel = sum(v[2] for k, v in raw.items() if k[2] in ("step_kernel", "run_steps"))
    total = sum(v[2] for v in raw.values())
    print(
        f"  profile: compiled step {kernel:.1f} s ({100 * kernel / max(total, 1e-300):.0f} % of "
        f"the profiled time; run_steps: the steps between records), Python around it "
        "(runner, records, energies) the rest"
    )
    print(
        f"  drag torque {s['drag_torque_Nm'] * NMM_PER_NM:.4f} N mm "
        f"(std {s['drag_torque_std_Nm'] * NMM_PER_NM:.3g}), power-balance error "
        f"{s['power_balance_error_relative']:.2g} of the input"
    )
    previous = PREVIOUS.get((scenario.name, scenario.duration))
    if previous is not None:
        date, step, cpu_then, evals, unconverged, drag, balance, load = previous
        print(
            f"  previous ({date}, semi-implicit, dt = {step * 1e6:g} us, docs/benchmarks.md, "
            f"load average {load:g}): CPU time {cpu_then:.1f} s ({cpu_then / max(cpu, 1e-300):.2f}"
            f" x this run), {evals:.2f} contact-law evaluations per step, {unconverged} steps "
            f"not converged, drag torque {drag * NMM_PER_NM:.4f} N mm "
            f"({100 * (s['drag_torque_Nm'] / drag - 1):+.3f} % now), power-balance error "
            f"{balance:.2g}"
        )
    return {
        "integrator": integrator_label(scenario),
        "cpu_s": cpu,
        "evaluations": float(work.get("contact_evaluations", math.nan)),
        "unconverged": int(s.get("unconverged_steps", 0)),
        "unconverged_in_hold": in_hold,
        "fallbacks": int(s.get("fallback_steps", 0)),
        "drag_Nm": float(s["drag_torque_Nm"]),
        "balance": float(s["power_balance_error_relative"]),
    }


def _side_by_side(rows: list[dict[str, Any]], reference: dict[str, Any] | None) -> None:
    """The runs of one benchmark call in a table; drags against ``reference`` when given."""
    print("side by side (CPU time of this process; the same machine state, one after another):")
    for row in rows:
        versus = ""
        if reference is not None:
            change = 100 * (row["drag_Nm"] / reference["drag_Nm"] - 1)
            versus = f" ({change:+.4f} % against {reference['integrator']})"
        print(
            f"  {row['integrator']}: CPU {row['cpu_s']:.1f} s, {row['evaluations']:.2f} "
            f"contact-law evaluations per step, unconverged {row['unconverged']} "
            f"({row['unconverged_in_hold']} listed in the hold), {row['fallbacks']} steps redone "
            "as substeps, drag "
            f"{row['drag_Nm'] * NMM_PER_NM:.4f} N mm{versus}, power-balance error "
            f"{100 * row['balance']:+.3f} %"
        )


def _scaling(scenario: Scenario, counts: list[int]) -> None:
    """CPU time per simulated second (all, and the hold after the speed ramp) at each number
    of spheres per nut, per sphere, and its growth against linear growth from the first."""
    print(
        f"cost against the number of spheres, scenario {scenario.name}, "
        f"{integrator_label(scenario)}, {scenario.duration:g} s simulated; one core (load average "
        f"{os.getloadavg()[0]:.1f} on {os.cpu_count()} cores)"
    )
    ramp_end = min(scenario.speed_ramp_end, scenario.duration)
    hold = scenario.duration - ramp_end
    first: tuple[int, float] | None = None
    for per_nut in counts:
        result, _, _, transient_cpu, hold_cpu = _timed_run(replace(scenario, balls_per_nut=per_nut))
        cpu = (transient_cpu + hold_cpu) / scenario.duration
        hold_rate = hold_cpu / hold if hold > 0 else math.nan
        work = result.summary.get("work_per_step", {})
        spheres = 2 * per_nut
        if first is None:
            first = (spheres, hold_rate)
        growth = (hold_rate / first[1]) / (spheres / first[0])
        print(
            f"  {per_nut:3d} per nut ({spheres:3d} spheres): CPU {cpu:.1f} s/s, hold "
            f"{hold_rate:.1f} s/s = {hold_rate / spheres:.2f} s/s per sphere (hold cost / "
            f"linear growth from {first[0]} spheres: {growth:.2f}); "
            f"{work.get('contact_evaluations', math.nan):.2f} contact-law evaluations per step",
            flush=True,
        )


def _convergence(scenario: Scenario, steps: list[float]) -> None:
    """Averaged drag torque at each time step, difference to the finest, observed order."""
    print(f"time-step convergence of the averaged drag torque, scenario {scenario.name}")
    values: dict[float, float] = {}
    for dt in sorted(steps):
        try:
            started = time.perf_counter()
            result = simulate(replace(scenario, time_step=dt))
        except BallscrewTwinError as err:
            print(f"  dt = {dt:g} s: failed ({err})")
            continue
        drag = float(result.summary["drag_torque_Nm"])
        values[dt] = drag
        print(
            f"  dt = {dt:g} s: drag {drag * NMM_PER_NM:.5f} N mm, wall "
            f"{time.perf_counter() - started:.0f} s, unconverged steps "
            f"{result.summary['unconverged_steps']}, balance "
            f"{result.summary['power_balance_error_relative']:.2g}",
            flush=True,
        )
    if len(values) < 2:
        return
    finest = min(values)
    ordered = sorted(values)
    print(f"  relative to dt = {finest:g} s:")
    for dt in ordered[1:]:
        print(f"    dt = {dt:g} s: {100 * (values[dt] / values[finest] - 1):+.3f} %")
    for a, b, c in zip(ordered, ordered[1:], ordered[2:], strict=False):
        fine, coarse = values[b] - values[a], values[c] - values[b]
        if fine != 0.0 and coarse != 0.0:
            order = math.log(abs(coarse / fine)) / math.log(c / b)
            print(f"    observed order from {a:g}, {b:g}, {c:g} s: {order:.2f}")


def corner_scenario(
    base: Scenario, preload: float, speed: float, temperature: float, time_step: float
) -> Scenario:
    """``base`` at one corner on the time-compressed protocol (CORNER_* timings).

    Args:
        base: scenario giving the parameter file, sphere count, controller, backend and
            integrator: with implicit sphere positions, the preload ramp and the standstill
            (until the speed ramp) are run at CORNER_TIME_STEP semi-implicit.
        preload: final preload [N]; speed: final screw speed [rad/s]; temperature: [K];
        time_step: integration step [s] (after that start phase).
    """
    implicit = base.implicit_positions
    return replace(
        base,
        name=f"corner_{preload:g}N_{speed / RPM:g}rpm_{temperature - CELSIUS_ZERO:g}C",
        preload=preload,
        speed=speed,
        temperature=temperature,
        preload_ramp_end=CORNER_PRELOAD_RAMP,
        speed_ramp_start=CORNER_SPEED_RAMP[0],
        speed_ramp_end=CORNER_SPEED_RAMP[1],
        duration=CORNER_DURATION,
        average_window=CORNER_WINDOW,
        time_step=time_step,
        output_interval=CORNER_OUTPUT,
        contact_output_interval=CORNER_OUTPUT,
        fine_time_step=CORNER_TIME_STEP if implicit else None,
        fine_until=CORNER_SPEED_RAMP[0] if implicit else 0.0,
    )


def corner_health(result: SimulationResult) -> dict[str, Any]:
    """Health of one finished run: non-finite values, blow-up, film, balance, drag (SI)."""
    sc = result.scenario
    s = result.summary
    series = [
        result.screw_speed,
        result.motor_torque,
        result.nut_force,
        result.nut_position,
        result.dissipation,
        result.power_balance_error,
        result.normal_force,
        result.film_thickness,
    ]
    finite = all(bool(np.all(np.isfinite(x))) for x in series)
    speed_bound = BLOWUP["speed_factor"] * abs(sc.speed) + BLOWUP["speed_margin_rad_s"]
    force_bound = BLOWUP["force_factor"] * sc.preload + BLOWUP["force_margin_N"]
    max_speed = float(np.max(np.abs(result.screw_speed)))
    max_nut_force = float(np.max(np.abs(result.nut_force)))
    max_normal = float(np.max(result.normal_force))
    active = result.in_contact
    window = result.contact_time >= sc.duration - sc.average_window - 0.5 * sc.time_step
    films = result.film_thickness[active]
    # Screw inertia torque J dOmega/dt over the window: the PI controller's overshoot still
    # settling in a short protocol. The summary's drag torque has it removed already; the
    # "drag torque" column keeps it (mean motor torque less the gravity torque).
    inertia_torque = float(s["inertia_torque_Nm"])
    window_films = result.film_thickness[window][active[window]]
    return {
        "finite": finite,
        "blow_up": not (
            max_speed <= speed_bound and max_nut_force <= force_bound and max_normal <= force_bound
        ),
        "max_screw_speed_rad_s": max_speed,
        "max_nut_force_N": max_nut_force,
        "max_normal_force_N": max_normal,
        "min_film_m": float(films.min()) if films.size else math.nan,
        "min_film_window_m": float(window_films.min()) if window_films.size else math.nan,
        "contacts_open_in_window": int(np.sum(~active[window])),
        "unconverged_steps": int(s["unconverged_steps"]),
        "fallback_steps": int(s.get("fallback_steps", 0)),
        "balance_error": float(s["power_balance_error_relative"]),
        "drag_torque_Nm": float(s["drag_torque_Nm"]) + inertia_torque,
        "drag_torque_std_Nm": float(s["drag_torque_std_Nm"]),
        "inertia_torque_Nm": inertia_torque,
        "drag_less_inertia_Nm": float(s["drag_torque_Nm"]),
    }


CORNER_COLUMNS = (
    "preload_N",
    "speed_rpm",
    "temperature_C",
    "finished",
    "finite",
    "blow_up",
    "max_screw_speed_rad_s",
    "max_nut_force_N",
    "max_normal_force_N",
    "min_film_m",
    "min_film_window_m",
    "contacts_open_in_window",
    "unconverged_steps",
    "fallback_steps",
    "steps",
    "balance_error",
    "drag_torque_Nm",
    "drag_torque_std_Nm",
    "inertia_torque_Nm",
    "drag_less_inertia_Nm",
    "wall_s",
    "cpu_s",
    "error",
)


def _corners(base: Scenario, time_step: float, out: Path | None) -> int:
    """Run every corner; print the table, write it to ``out``; 1 when a corner fails."""
    rows: list[dict[str, Any]] = []
    failed = 0
    corners = [
        (p, n, c) for c in CORNER_TEMPERATURES_C for n in CORNER_SPEEDS_RPM for p in CORNER_PRELOADS
    ]
    label = integrator_label(corner_scenario(base, 0.0, 0.0, CELSIUS_ZERO, time_step))
    print(
        f"envelope corners: {len(corners)} runs of {CORNER_DURATION:g} s, {label}, "
        f"preload ramp {CORNER_PRELOAD_RAMP:g} s, speed ramp {CORNER_SPEED_RAMP[0]:g}-"
        f"{CORNER_SPEED_RAMP[1]:g} s, averaged over the last {CORNER_WINDOW:g} s; "
        f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores",
        flush=True,
    )
    for preload, rpm, celsius in corners:
        scenario = corner_scenario(base, preload, rpm * RPM, celsius + CELSIUS_ZERO, time_step)
        row: dict[str, Any] = {"preload_N": preload, "speed_rpm": rpm, "temperature_C": celsius}
        row["steps"] = scenario.steps
        started, cpu0 = time.perf_counter(), time.process_time()
        try:
            result = simulate(scenario)
        except BallscrewTwinError as err:
            row.update(finished=False, finite=False, blow_up=True, error=str(err))
        else:
            row.update(finished=True, error="", **corner_health(result))
        row["wall_s"] = time.perf_counter() - started
        row["cpu_s"] = time.process_time() - cpu0
        ok = (
            row["finished"]
            and row["finite"]
            and not row["blow_up"]
            and row["min_film_m"] >= 0.0
            and not row["min_film_window_m"] <= 0.0
        )
        failed += not ok
        rows.append(row)
        print(_corner_line(row, ok), flush=True)
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
        with open(out / "corners.csv", "w", newline="") as handle:
            writer = csv.DictWriter(handle, fieldnames=list(CORNER_COLUMNS), restval="")
            writer.writeheader()
            writer.writerows(rows)
        (out / "corners.md").write_text(_corner_markdown(rows, base, time_step))
        print(f"wrote {out / 'corners.csv'} and {out / 'corners.md'}")
    print(f"{len(rows) - failed} of {len(rows)} corners healthy")
    return 1 if failed else 0


def _corner_line(row: dict[str, Any], ok: bool) -> str:
    """One printed line of the corner table."""
    head = f"  {row['preload_N']:6.0f} N {row['speed_rpm']:6.0f} rpm {row['temperature_C']:+4.0f} C"
    if not row["finished"]:
        return f"{head}: FAILED after {row['wall_s']:.0f} s wall: {row['error']}"
    return (
        f"{head}: {'ok' if ok else 'UNHEALTHY'}; finite {row['finite']}, blow-up "
        f"{row['blow_up']} (max speed {row['max_screw_speed_rad_s']:.4g} rad/s, nut force "
        f"{row['max_nut_force_N']:.4g} N, contact force {row['max_normal_force_N']:.4g} N), "
        f"min film {row['min_film_m'] * 1e9:.4g} nm (window {row['min_film_window_m'] * 1e9:.4g}"
        f" nm), unconverged {row['unconverged_steps']} of {row['steps']} (redone as substeps "
        f"{row['fallback_steps']}), balance "
        f"{row['balance_error']:+.2g}, drag {row['drag_torque_Nm'] * NMM_PER_NM:.4f} N mm "
        f"(less J dOmega/dt: {row['drag_less_inertia_Nm'] * NMM_PER_NM:.4f}); "
        f"wall {row['wall_s']:.0f} s, CPU {row['cpu_s']:.0f} s"
    )


def _corner_markdown(rows: list[dict[str, Any]], base: Scenario, time_step: float) -> str:
    """The corner table as markdown."""
    lines = [
        f"Envelope corners (`bench protocol --corners`, base scenario {base.name}, "
        f"{integrator_label(corner_scenario(base, 0.0, 0.0, CELSIUS_ZERO, time_step))}, "
        f"{CORNER_DURATION * 1e3:g} ms per run)",
        "",
        "| preload | speed | T | finished | finite | blow-up | min film (window) | "
        "unconverged (redone) | balance | drag (less J dOmega/dt) | wall / CPU |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for r in rows:
        if not r["finished"]:
            lines.append(
                f"| {r['preload_N']:g} N | {r['speed_rpm']:g} rpm | {r['temperature_C']:g} C | "
                f"no: {r['error']} | | | | | | | {r['wall_s']:.0f} / {r['cpu_s']:.0f} s |"
            )
            continue
        lines.append(
            f"| {r['preload_N']:g} N | {r['speed_rpm']:g} rpm | {r['temperature_C']:g} C | yes | "
            f"{'yes' if r['finite'] else 'NO'} | {'YES' if r['blow_up'] else 'no'} | "
            f"{r['min_film_m'] * 1e9:.3g} nm ({r['min_film_window_m'] * 1e9:.3g} nm) | "
            f"{r['unconverged_steps']} / {r['steps']} ({r['fallback_steps']}) | "
            f"{100 * r['balance_error']:+.2f} % | "
            f"{r['drag_torque_Nm'] * NMM_PER_NM:.3f} "
            f"({r['drag_less_inertia_Nm'] * NMM_PER_NM:.3f}) N mm | "
            f"{r['wall_s']:.0f} / {r['cpu_s']:.0f} s |"
        )
    return "\n".join(lines) + "\n"


def run(args: argparse.Namespace) -> int:
    """Run the benchmark; print its numbers."""
    scenario = _scenario(args)
    if args.corners:
        default = CORNER_IMPLICIT_STEP if scenario.implicit_positions else CORNER_TIME_STEP
        return _corners(scenario, args.time_step or default, Path(args.out) if args.out else None)
    if args.scaling:
        _scaling(scenario, [int(x) for x in args.scaling.split(",") if x.strip()])
        return 0
    if args.convergence:
        steps = [float(x) for x in args.convergence.split(",") if x.strip()]
        _convergence(scenario, steps)
        return 0
    rows = [_run_once(scenario)]
    reference = None
    for step, is_reference in ((args.baseline, False), (args.reference, True)):
        if step is not None:
            rows.append(_run_once(semi_implicit(scenario, step)))
            reference = rows[-1] if is_reference else reference
    if len(rows) > 1:
        _side_by_side(rows, reference)
    if args.full:
        paper = load_scenario(SCENARIO_DIR / "paper_protocol.yaml")
        if args.time_step is not None:
            paper = replace(paper, time_step=args.time_step)
        started = time.perf_counter()
        result = simulate(paper)
        wall = time.perf_counter() - started
        s = result.summary
        print(
            f"paper protocol: wall time {wall:.0f} s = {wall / 60:.1f} min, drag torque "
            f"{s['drag_torque_Nm'] * NMM_PER_NM:.4f} N mm, balance "
            f"{s['power_balance_error_relative']:.2g}, unconverged {s['unconverged_steps']}"
        )
    return 0
