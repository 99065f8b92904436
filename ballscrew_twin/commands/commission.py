"""``ballscrew-twin commission BAG [BAG ...] --out baseline.yaml``: learn the healthy unit from
one healthy recording or several of the same unit, fitted together (a cold start and a run at
the speeds and temperatures it serves at: the monitor is sharpest where the commissioning
taught it). Several recordings fitted together raised false alarms in held-out testing where
the cold start alone raised none (docs/benchmarks.md, rounds 23 and 25: 8 and 1; round 24:
none), and the command says so.

The fit and its error model: :mod:`ballscrew_twin.health.commission`. The bags' topics are
chosen as for ``detect``.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np

from ..bags.bench import read_bench_bag
from ..health.baseline import BAND_REACH, SHIFT_EXTRAPOLATION
from ..health.commission import ERROR_SCALE, TEMPERATURE_ERROR, UNSEEN_ERROR, commission
from ..health.correction import MIN_SUPPORT
from ..health.offline import CHANNELS, recording_channels
from ..params import load_config
from ..plots.commissioning import plot_commissioning
from .detect import add_topic_arguments, bench_topics
from .map import ensure_friction_response


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``commission``."""
    parser.add_argument(
        "bag",
        nargs="+",
        help="healthy recording(s) of the unit: bag folders or files (mcap or sqlite3), fitted "
        "together",
    )
    parser.add_argument("--out", required=True, help="baseline YAML file to write")
    parser.add_argument("--config", default=None, help="screw parameter YAML (default: paper)")
    parser.add_argument("--plot", default=None, help="also write a PNG of the fit here")
    parser.add_argument(
        "--error-scale",
        type=float,
        default=ERROR_SCALE,
        help="model error = this x the fit's 95th-percentile error / 1.96 [-]",
    )
    parser.add_argument(
        "--unseen-error",
        type=float,
        default=UNSEEN_ERROR,
        help="least 1-sigma relative model error where the recording did not teach the twin "
        "(speeds and temperatures it hardly visited) [-]",
    )
    parser.add_argument(
        "--temperature-error",
        type=float,
        default=TEMPERATURE_ERROR,
        help="growth of the model error per kelvin outside the temperatures the recording saw "
        "at a speed (e_T) [1/K]",
    )
    parser.add_argument(
        "--shift-extrapolation",
        type=float,
        default=SHIFT_EXTRAPOLATION,
        help="the fitted temperature shift at which the twin's whole change of drag beyond "
        "the temperatures the recording saw counts as its 1-sigma error there [K]",
    )
    parser.add_argument(
        "--band-reach",
        type=float,
        default=BAND_REACH,
        help="the temperatures the recording saw count within this many decades of a speed; "
        "0: those seen in its speed band (split at 3, 10, 30, 100, 300 rad/s) [-]",
    )
    add_topic_arguments(parser)


def run(args: argparse.Namespace) -> int:
    """Fit, write the baseline (and the plot), print the fitted values."""
    recordings = [read_bench_bag(bag, bench_topics(args), required=CHANNELS) for bag in args.bag]
    config = load_config(args.config)
    ensure_friction_response(config)
    result = commission(
        [recording_channels(r) for r in recordings],
        config,
        source=" + ".join(Path(bag).name for bag in args.bag),
        error_scale=args.error_scale,
        unseen_error=args.unseen_error,
        temperature_error=args.temperature_error,
        shift_extrapolation=args.shift_extrapolation,
        band_reach=args.band_reach,
    )
    for bag, recording in zip(args.bag, recordings, strict=True):
        where = f"{Path(bag).name}: " if len(recordings) > 1 else ""
        for issue in recording.issues:
            print(f"note: {where}{issue}")
    b, u = result.baseline, result.uncertainty
    print(
        f"fitted on {b.blocks} blocks ({result.gated_share:.1%} of the recording gated): "
        f"gain {b.torque_gain:.4f} +- {u['torque_gain']:.4f}, "
        f"bias {b.torque_bias * 1e3:.3f} +- {u['torque_bias'] * 1e3:.3f} mN m, "
        f"preload scale {b.preload_scale:.3f} +- {u['preload_scale']:.3f}, "
        f"temperature shift {b.temperature_shift:.2f} +- {u['temperature_shift']:.2f} K, "
        f"inertia {b.inertia:.4g} +- {u['inertia']:.2g} kg m^2, "
        f"mu_dry scale {b.dry_friction_scale:.3f} +- {u['dry_friction_scale']:.3f}, "
        f"tau_0 scale {b.eyring_scale:.3f} +- {u['eyring_scale']:.3f}; "
        f"model error {b.error_relative:.2%} (1 sigma), sensor noise "
        f"{(b.sensor_noise or math.nan) * 1e3:.3f} mN m"
    )
    for name in result.at_bounds:
        print(
            f"note: {name} ended on a bound of the fit: the recording did not pin the unit "
            "down (it trades against the other values), so the baseline is doubtful; record "
            "a run over more speeds, temperatures and preloads, or check the torque's units "
            "and sign"
        )
    if b.surface is not None:
        taught = int(np.count_nonzero(b.surface.support >= MIN_SUPPORT))
        print(
            f"residual surface taught at {taught} of {b.surface.support.size} nodes of speed and "
            f"temperature (support >= {MIN_SUPPORT:g} blocks; hatched elsewhere in --plot); "
            f"where it is not taught the twin's error is taken as {b.unseen_error:.2%} (1 sigma): "
            "commission over the speeds and temperatures the unit will run at"
        )
    print(
        f"temperatures seen: {b.temperature_min - 273.15:.1f} to {b.temperature_max - 273.15:.1f} "
        f"C; outside those seen at a speed the twin's error grows by "
        f"{b.temperature_error:.2%} per K (--temperature-error), and by the twin's change "
        f"there times |shift| / {b.shift_extrapolation:g} K (--shift-extrapolation); "
        + (
            f"seen at a speed: within {b.band_reach:g} decades of it (--band-reach)"
            if b.band_reach > 0.0
            else "seen at a speed: in its speed band (--band-reach 0)"
        )
    )
    if len(recordings) > 1:
        print(
            "caution: fitted together, several recordings of a unit raised false alarms in "
            "held-out testing where its cold start alone raised none (docs/health.md, rounds "
            "23-25): prefer one healthy recording that covers the unit's speeds and "
            "temperatures"
        )
    print(f"wrote {b.save(args.out)}")
    if args.plot:
        print(f"wrote {plot_commissioning(result, args.plot)}")
    return 0
