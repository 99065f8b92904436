"""``ballscrew-twin calibrate``: fit the parameters the paper omits to drag-torque targets.

The targets (the paper's statement, a CSV or a bench bag), the fit and its uncertainties:
:mod:`ballscrew_twin.calibration`. Speeds in rpm and temperatures in degrees Celsius are printed
for the targets; everything written is SI.
"""

from __future__ import annotations

import argparse
import json
import sys

from ..calibration import (
    DEFAULT_PARAMETERS,
    SteadyCriteria,
    calibrate,
    load_targets,
    parameter_unit,
    plot_calibration,
    refuse_outside_envelope,
    write_config,
    write_targets,
)
from ..params import check_number, load_config, positive
from ..units import CELSIUS_ZERO, RPM
from .detect import add_topic_arguments, bench_topics


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``calibrate``."""
    parser.add_argument("--config", default=None, help="starting parameter YAML (default: paper)")
    parser.add_argument(
        "--data",
        default=None,
        help="CSV of speed_rpm,temperature_C,preload_N,torque_Nm, or a bench bag (folder, "
        ".mcap or .db3; its steady segments are the targets) (default: the paper's Eq. 52 "
        "statement at 100 rpm, 20 and 60 C)",
    )
    parser.add_argument(
        "--steady-window",
        type=float,
        default=SteadyCriteria.window,
        help="bag: length of the windows a steady segment is made of [s] (default: %(default)s)",
    )
    add_topic_arguments(parser)
    parser.add_argument(
        "--parameters",
        nargs="+",
        default=list(DEFAULT_PARAMETERS),
        help="lubricant/contact parameters to fit (default: %(default)s)",
    )
    parser.add_argument("--out", default=None, help="write the fitted parameter set here (YAML)")
    parser.add_argument(
        "--plot",
        default=None,
        metavar="PNG",
        help="measured vs predicted, residuals, fitted values",
    )
    parser.add_argument(
        "--save-targets", default=None, metavar="CSV", help="write the targets used here (CSV)"
    )
    parser.add_argument("--json", action="store_true", help="print the result as JSON")


def run(args: argparse.Namespace) -> int:
    """Fit, print the misfit; optionally write the YAML, the targets and the plot."""
    check_number(args.steady_window, positive("s"), "--steady-window", text=False)
    config = load_config(args.config)

    def log(line: str) -> None:  # with --json, stdout carries the JSON only
        print(line, file=sys.stderr if args.json else sys.stdout, flush=True)

    targets, name = load_targets(args, bench_topics(args), log)
    if args.data is not None:
        refuse_outside_envelope(targets, config, args.data)
    if args.save_targets:
        log(f"wrote {write_targets(targets, args.save_targets)}")
    log(f"calibrating {', '.join(args.parameters)} against {len(targets)} targets: {name}")
    result = calibrate(config, targets, args.parameters, progress=not args.json)
    summary = {
        "parameters": result.values,
        "uncertainty": result.uncertainty,
        "initial": result.initial,
        "rms_relative_error": result.rms_relative_error,
        "max_relative_error": result.max_relative_error,
        "evaluations": result.evaluations,
        "wall_time_s": result.wall_time,
        "targets": [
            {
                "speed_rad_s": t.point.screw_speed,
                "temperature_K": t.point.temperature,
                "preload_N": t.point.preload,
                "target_Nm": t.torque,
                "predicted_Nm": p,
                "relative_error": e,
            }
            for t, p, e in zip(targets, result.predicted, result.relative_errors, strict=True)
        ],
    }
    if args.json:
        print(json.dumps(summary, indent=2))
    else:
        for t, e in zip(targets, result.relative_errors, strict=True):
            print(
                f"  {t.point.screw_speed / RPM:7.1f} rpm "
                f"{t.point.temperature - CELSIUS_ZERO:6.1f} C "
                f"{t.point.preload:7.1f} N: target {t.torque * 1e3:8.3f} mN m, error {e:+.4f}"
            )
        fitted = ", ".join(
            f"{k} = {v:.6g} +- {result.uncertainty[k]:.2g} {parameter_unit(k)}"
            for k, v in result.values.items()
        )
        print(
            f"fitted {fitted}; rms relative error {result.rms_relative_error:.4f}, max "
            f"{result.max_relative_error:.4f} ({result.evaluations} evaluations, "
            f"{result.wall_time:.1f} s)"
        )
    if args.out:
        write_config(result, name, args.out)
        log(f"wrote {args.out}")
    if args.plot:
        log(f"wrote {plot_calibration(result, targets, name, args.plot)}")
    return 0
