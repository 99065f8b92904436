"""``ballscrew-twin report paper|gaps``: the command's options and what each report runs.

``paper`` sweeps the paper's grid with the steady model (:mod:`.paper`) and writes Figs. 9-11
and their CSV; ``gaps`` runs the studies of :mod:`.gaps` and writes gaps.json. Both write to
``--out``.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from ..params import load_config
from ..report import gaps
from ..report.paper import CSV_NAME, paper_sweep, plot_paper, write_csv


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``report``: the shared ones, then those of the gaps studies."""
    parser.add_argument(
        "what",
        choices=("paper", "gaps"),
        help="paper: the paper's figures; gaps: the open gaps against it, measured",
    )
    parser.add_argument("--out", required=True, type=Path, help="output directory")
    parser.add_argument("--config", default=None, help="parameter YAML (default: paper screw)")
    parser.add_argument("--quick", action="store_true", help="coarse grid (seconds, for tests)")
    gaps.add_arguments(parser)


def run(args: argparse.Namespace) -> int:
    """Run the chosen report (:func:`run_paper` or :func:`ballscrew_twin.report.gaps.run`)."""
    if args.what == "gaps":
        return gaps.run(args)
    return run_paper(args)


def run_paper(args: argparse.Namespace) -> int:
    """``report paper``: sweep, write the CSV and the PNGs, print how many points converged
    (and which did not) and the wall time."""
    start = time.perf_counter()
    rows = paper_sweep(load_config(args.config), args.quick)
    out_dir = Path(args.out)
    paths = plot_paper(rows, out_dir)
    paths.append(write_csv(rows, out_dir / CSV_NAME))
    points = {(r["temperature_C"], r["speed_rpm"], r["preload_N"]): r["status"] for r in rows}
    failed = {point: status for point, status in points.items() if status != "ok"}
    for path in paths:
        print(f"wrote {path}")
    print(f"{len(points) - len(failed)} of {len(points)} operating points converged")
    for (temperature, speed, preload), status in failed.items():
        print(f"  failed: {temperature:g} °C, {speed:g} rpm, {preload:g} N: {status}")
    print(f"wall time {time.perf_counter() - start:.1f} s")
    return 0
