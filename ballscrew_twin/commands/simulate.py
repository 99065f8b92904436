"""``ballscrew-twin simulate``: run a scenario through the dynamic model and write its outputs.

Writes into ``--out``: ``timeseries.csv``, ``result.npz``, ``simulation.mcap`` (a rosbag2
folder, unless ``--no-bag``), ``simulation.png`` and ``summary.json`` (SI units, scenario
echoed), and prints the summary. Progress (simulated time, ETA) goes to stderr. An invalid
scenario or parameter file exits with status 2 and a message naming the file and the field.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from ..errors import BallscrewTwinError
from ..models.scenario import load_scenario
from ..models.simulation import simulate
from ..models.simulation_result import SimulationResult

NMM_PER_NM = 1e3
UNRELIABLE_BREAKDOWN = 0.01  # relative power-balance error above which the breakdown is flagged


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``simulate``."""
    parser.add_argument("--scenario", required=True, help="scenario YAML (SI units)")
    parser.add_argument("--out", required=True, help="output folder (created if missing)")
    parser.add_argument("--no-bag", action="store_true", help="do not write the rosbag2")
    parser.add_argument("--storage", default="mcap", choices=("mcap", "sqlite3"))
    parser.add_argument("--quiet", action="store_true", help="no progress bar")


def format_summary(result: SimulationResult) -> str:
    """Human-readable summary: drag in N m and N mm, settling, breakdown, balance, solver."""
    s = result.summary
    sc = result.scenario
    drag = s["drag_torque_Nm"]
    std_from, std_to = s["drag_torque_std_window_s"]
    lines = [
        f"scenario {sc.name}: {sc.temperature:.2f} K, preload {sc.preload:.6g} N, "
        f"speed {sc.speed:.6g} rad/s, {s['balls_per_nut']} spheres per nut",
        f"averaged over {s['window_start_s']:.6g} .. {s['window_end_s']:.6g} s "
        f"(mean speed {s['mean_screw_speed_rad_s']:.6g} rad/s)",
        f"drag torque      {drag:.6g} N m = {drag * NMM_PER_NM:.6g} N mm "
        f"(std {s['drag_torque_std_Nm'] * NMM_PER_NM:.4g} N mm over "
        f"{std_from:.6g} .. {std_to:.6g} s)",
        f"  motor torque   {s['mean_motor_torque_Nm']:.6g} N m",
        f"  gravity torque {s['gravity_torque_Nm']:.6g} N m (removed)",
        f"  inertia torque {s['inertia_torque_Nm']:.6g} N m (I_s dOmega/dt, removed)",
    ]
    if s["settled"]:
        lines.append(f"settled: yes, since {s['settled_since_s']:.6g} s (before the window)")
    else:
        lines.append(
            "settled: NO, the drag above is not a steady value: "
            + "; ".join(s["not_settled_because"])
        )
    lines.append("breakdown (mean power / mean speed; sums to the drag):")
    for name, value in s["breakdown_Nm"].items():
        lines.append(f"  {name:<18} {value:.6g} N m = {value * NMM_PER_NM:.6g} N mm")
    lines += [
        f"  {'sum':<18} {s['breakdown_total_Nm']:.6g} N m "
        f"(dissipation alone {s['dissipation_drag_Nm'] * NMM_PER_NM:.6g} N mm)",
        f"power-balance error {s['power_balance_error_J']:.4g} J "
        f"({s['power_balance_error_relative']:.3g} of the gross input energy "
        f"{s['gross_input_energy_J']:.4g} J)",
        f"wall time {s['wall_time_s']:.3f} s, {s['steps']} steps "
        f"({s['step_cost_s'] * 1e3:.3g} ms/step), real-time factor {s['real_time_factor']:.3g}",
        *_unconverged_lines(s["unconverged"]),
    ]
    work = s.get("work_per_step", {})
    if work.get("contact_evaluations"):
        lines.append(
            f"work per step: {work['contact_evaluations']:.2f} contact-law evaluations, "
            f"{work['jacobians']:.3f} Jacobians, {work['newton_iterations']:.2f} Newton iterations"
        )
    if not abs(s["power_balance_error_relative"]) < UNRELIABLE_BREAKDOWN:
        lines.append(
            "WARNING: the power balance does not close to 1 %: the breakdown above is not "
            "reliable (try a smaller time_step); docs/model.md, section 10"
        )
    return "\n".join(lines)


def _unconverged_lines(u: dict[str, Any]) -> list[str]:
    """What the summary says about steps whose Newton iterations did not converge."""
    if not u["count"]:
        return [f"Newton iterations converged (scaled residual < {u['tolerance']:g}) at every step"]
    lines = [
        f"{u['count']} of {u['steps']} steps ended with the Newton iterations not converged "
        f"(scaled residual above {u['tolerance']:g}; {u['in_window']} in the averaging window; "
        f"each such step is kept as it stands); largest residual {u['largest_residual']:.3g}:"
    ]
    lines += [
        f"  step {st['step']} at t = {st['time_s']:.7g} s: residual {st['residual']:.3g}"
        for st in u["listed"]
    ]
    if u["unlisted"]:
        lines.append(f"  ... and {u['unlisted']} more steps (not listed)")
    return lines


def _progress_bar(total_time: float, quiet: bool) -> tuple[Any, Any]:
    """A tqdm bar in simulated seconds on stderr and the callback that advances it."""
    from tqdm import tqdm

    bar = tqdm(
        total=total_time,
        unit="s sim",
        unit_scale=False,
        file=sys.stderr,
        disable=quiet,
        bar_format="{l_bar}{bar}| {n:.4g}/{total:.4g} s simulated [{elapsed}<{remaining}]",
    )

    def advance(fraction: float, elapsed: float) -> None:
        bar.update(fraction * total_time - bar.n)

    return bar, advance


def run(args: argparse.Namespace) -> int:
    """``simulate``: run, write every output, print the summary."""
    from ..results import plot_contacts, plot_result, summary_json, write_bag, write_csv, write_npz

    scenario = load_scenario(args.scenario)
    out = Path(args.out)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise BallscrewTwinError(f"{out}: cannot create output folder ({err.strerror})") from err
    bag = out / "simulation.mcap"
    if not args.no_bag and bag.exists():
        raise BallscrewTwinError(f"{bag}: exists already; remove it or choose another --out")
    bar, advance = _progress_bar(scenario.duration, args.quiet)
    try:
        result = simulate(scenario, progress=advance)
    finally:
        bar.close()
    write_csv(result, out / "timeseries.csv")
    write_npz(result, out / "result.npz")
    if not args.no_bag:
        write_bag(result, bag, storage=args.storage)
    plot_result(result, out / "simulation.png")
    plot_contacts(result, out / "contact_states.png")
    (out / "summary.json").write_text(summary_json(result) + "\n", encoding="utf-8")
    print(format_summary(result))
    print(f"outputs in {out}")
    return 0
