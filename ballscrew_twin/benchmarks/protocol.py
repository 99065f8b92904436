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
  step, its difference to the finest one and the observed order.

It measures; it never asserts a speed. Times in s, torques in N m (printed also in N mm).
"""

from __future__ import annotations

import argparse
import cProfile
import math
import os
import pstats
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

from ..errors import BallscrewTwinError
from ..models.scenario import Scenario, load_scenario
from ..models.simulation import SimulationResult, simulate

#: One-line help of this benchmark.
DESCRIPTION = "cost of the paper protocol on the dynamic model (and its time-step convergence)"

SCENARIO_DIR = Path(__file__).resolve().parents[2] / "config" / "scenarios"
PAPER_TRANSIENT = 0.1  # s, end of the paper's speed ramp
PAPER_DURATION = 0.6  # s, the paper's protocol
NMM_PER_NM = 1e3


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
    return replace(scenario, **changes) if changes else scenario


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


def _run_once(scenario: Scenario) -> None:
    """Cost of one run with its profile summary."""
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
        f"scenario {scenario.name}: {spheres} spheres, dt = {scenario.time_step:g} s, "
        f"{scenario.duration:g} s simulated, {s['steps']} steps; one core (pid {os.getpid()}, "
        f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores)"
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
    )
    stats = pstats.Stats(profile)
    raw = stats.stats  # type: ignore[attr-defined]
    kernel = sum(v[2] for k, v in raw.items() if k[2] == "step_kernel")
    total = sum(v[2] for v in raw.values())
    print(
        f"  profile: compiled step {kernel:.1f} s ({100 * kernel / max(total, 1e-300):.0f} % of "
        f"the profiled time), Python around it (runner, records, energies) the rest"
    )
    print(
        f"  drag torque {s['drag_torque_Nm'] * NMM_PER_NM:.4f} N mm "
        f"(std {s['drag_torque_std_Nm'] * NMM_PER_NM:.3g}), power-balance error "
        f"{s['power_balance_error_relative']:.2g} of the input"
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


def run(args: argparse.Namespace) -> int:
    """Run the benchmark; print its numbers."""
    scenario = _scenario(args)
    if args.convergence:
        steps = [float(x) for x in args.convergence.split(",") if x.strip()]
        _convergence(scenario, steps)
        return 0
    _run_once(scenario)
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
