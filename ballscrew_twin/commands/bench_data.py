"""``ballscrew-twin bench-data``: recorded bench bags generated from the twin, and what a bag holds.

Subcommands:

- ``generate --scene FILE --out BAG [--seed N] [--storage mcap|sqlite3] [--plot PNG]``: one bag
  (schema of :mod:`~ballscrew_twin.bags.bench`) and its side file ``BAG.truth.json``; the
  scene's operating profile is first checked against the validity envelope (docs/model.md
  section 13) and refused outside it with one line naming the file;
- ``samples [--out DIR]``: the committed sample bags ``data/samples/<name>`` from
  ``config/bench_scenes/<name>.yaml`` (healthy and one per fault class), deterministically;
- ``unit --unit N --seed S --duration D --out BAG [--fault CLASS:SEVERITY:ONSET]``: a bag of
  a drawn unit that is not the twin (:mod:`~ballscrew_twin.health.bench_units`) through a
  random EMA duty cycle (:mod:`~ballscrew_twin.health.duty_cycles`), truth side file included;
- ``info BAG``: channels, sample counts and rates, ground truth and reading issues of a bag.

How a bag is made: :mod:`ballscrew_twin.health.bench_data`.
"""

from __future__ import annotations

import argparse
import shutil
from pathlib import Path

import numpy as np

from ..bags.bench import read_bench_bag
from ..bags.bench_writer import write_bench_bag
from ..bags.recording import truth_path
from ..errors import ConfigError
from ..health.bench_data import (
    SAMPLE_DIR,
    SAMPLE_NAMES,
    SCENE_DIR,
    START_NS,
    BenchData,
    generate,
    generate_unit_data,
)
from ..health.bench_scene import load_bench_scene
from ..health.bench_units import draw_unit
from ..health.duty_cycles import COMMISSIONING_WARMUP, draw_trajectory
from ..health.fault_profiles import DEFAULT_GROWTH, FaultSpec, faults_from_list
from ..models.base import OperatingPoint
from ..models.validity import ValidityEnvelope, refuse_outside
from ..params import load_config
from ..plots.bench_data import plot_bench_data
from .progress import progress_bar


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``bench-data``."""
    sub = parser.add_subparsers(dest="action", required=True)
    gen = sub.add_parser("generate", help="generate one bench bag from a scene file")
    gen.add_argument("--scene", required=True, help="bench scene YAML (config/bench_scenes/)")
    gen.add_argument("--out", required=True, help="bag folder to create (must not exist)")
    gen.add_argument("--seed", type=int, default=None, help="noise seed (default: the scene's)")
    gen.add_argument("--storage", default="mcap", choices=("mcap", "sqlite3"))
    gen.add_argument("--plot", default=None, help="also write a PNG of the channels here")
    unit = sub.add_parser(
        "unit",
        help="a bag of a drawn unit (not the twin) through a random EMA duty cycle",
    )
    unit.add_argument("--out", required=True, help="bag folder to create (must not exist)")
    unit.add_argument("--unit", type=int, default=0, help="unit number (seeds the unit) [-]")
    unit.add_argument("--seed", type=int, default=0, help="seed of the duty cycle and noise [-]")
    unit.add_argument("--duration", type=float, default=60.0, help="length [s]")
    unit.add_argument("--preload", type=float, default=1500.0, help="set preload [N]")
    unit.add_argument(
        "--temperature",
        choices=("ambient", "cold-start", "random", "warm-up"),
        default="random",
        help="ambient 10-35 C, a cold start from -20..5 C, 1 in 4 cold (random), or a "
        "commissioning warm-up from -20..-10 C to 35..45 C within a few minutes",
    )
    unit.add_argument(
        "--fault",
        default=None,
        metavar="CLASS:SEVERITY:ONSET",
        help="inject one fault, e.g. preload_loss:0.05:30 (onset in s, growth the class's)",
    )
    unit.add_argument("--storage", default="mcap", choices=("mcap", "sqlite3"))
    unit.add_argument("--plot", default=None, help="also write a PNG of the channels here")
    samples = sub.add_parser("samples", help="regenerate the sample bags of data/samples")
    samples.add_argument("--out", default=str(SAMPLE_DIR), help="folder of the sample bags")
    info = sub.add_parser("info", help="channels, rates, truth and issues of a bag")
    info.add_argument("bag", help="bag folder or .mcap/.db3 file")


def _info(bag: str) -> int:
    """Print what :func:`read_bench_bag` finds in ``bag``."""
    rec = read_bench_bag(bag, required=())
    print(f"{rec.path}: {rec.storage}, {rec.duration:.3f} s")
    for name, series in rec.channels.items():
        rate = (len(series) - 1) / (series.time[-1] - series.time[0]) if len(series) > 1 else 0.0
        print(
            f"  {name:<12} {series.topic:<22} {len(series):7d} samples  {rate:8.2f} Hz  "
            f"mean {float(np.mean(series.value)):.6g} {series.unit}"
        )
    if rec.truth is not None:
        faults = rec.truth.get("faults", [])
        print(
            f"  truth: scene {rec.truth.get('scene')}, seed {rec.truth.get('seed')}, "
            f"faults {[(f['class'], f['onset_s'], f['severity']) for f in faults] or 'none'}"
        )
    for issue in rec.issues:
        print(f"  issue: {issue}")
    return 0


def _fault_argument(text: str) -> FaultSpec:
    """``CLASS:SEVERITY:ONSET`` -> a fault with the class's default growth."""
    parts = text.split(":")
    if len(parts) != 3 or parts[0] not in DEFAULT_GROWTH:
        raise ConfigError(
            f"--fault {text!r}: expected CLASS:SEVERITY:ONSET with CLASS one of "
            f"{sorted(DEFAULT_GROWTH)}"
        )
    growth = DEFAULT_GROWTH[parts[0]]
    return faults_from_list(
        [
            {
                "class": parts[0],
                "severity": parts[1],
                "onset": parts[2],
                "growth": growth,
                "growth_time": 0.0 if growth == "step" else 1.0,
            }
        ],
        "--fault",
    )[0]


def _unit_bag(args: argparse.Namespace) -> BenchData:
    """``bench-data unit``: a drawn unit through a random duty cycle, written as a bag."""
    cold = {"ambient": False, "cold-start": True, "random": None, "warm-up": True}
    trajectory = draw_trajectory(
        args.seed,
        args.duration,
        cold_start=cold[args.temperature],
        preload=args.preload,
        warmup=COMMISSIONING_WARMUP if args.temperature == "warm-up" else None,
    )
    faults = (_fault_argument(args.fault),) if args.fault else ()
    config = load_config(None)
    data = generate_unit_data(
        config,
        draw_unit(args.unit),
        trajectory,
        faults=faults,
        seed=args.seed,
        name=f"unit {args.unit}",
    )
    write_bench_bag(data, args.out, START_NS, storage=args.storage)
    return data


def generate_bag(
    scene_file: str | Path,
    out: str | Path,
    seed: int | None = None,
    storage: str = "mcap",
    progress: bool = False,
) -> BenchData:
    """Load a scene, generate it (a progress bar on stderr with ``progress``) and write the
    bag ``out`` (+ side file); returns the data."""
    scene = load_bench_scene(scene_file)
    with progress_bar(f"twin {scene.name}", "pt", enabled=progress) as advance:
        data = generate(scene, seed=seed, on_progress=advance)
    write_bench_bag(data, out, START_NS, storage=storage)
    return data


def regenerate_samples(out: str | Path = SAMPLE_DIR, progress: bool = False) -> list[Path]:
    """Write every sample bag ``<out>/<name>`` (+ side file) from its scene, replacing old ones."""
    folder = Path(out)
    folder.mkdir(parents=True, exist_ok=True)
    written = []
    for name in SAMPLE_NAMES:
        bag = folder / name
        if bag.exists():
            shutil.rmtree(bag)
        truth_path(bag).unlink(missing_ok=True)
        generate_bag(SCENE_DIR / f"{name}.yaml", bag, progress=progress)
        written.append(bag)
    return written


def _run(args: argparse.Namespace) -> int:
    """``bench-data``: generate, unit, samples or info."""
    if args.action == "info":
        return _info(args.bag)
    if args.action == "unit":
        data = _unit_bag(args)
        print(
            f"wrote {args.out} (unit {args.unit}, {len(data.torque)} torque samples, "
            f"{len(data.faults)} fault(s)) and {truth_path(args.out)}"
        )
        if args.plot:
            print(f"wrote {plot_bench_data(data, args.plot)}")
        return 0
    if args.action == "samples":
        for bag in regenerate_samples(args.out, progress=True):
            print(f"wrote {bag} and {truth_path(bag).name}")
        return 0
    data = generate_bag(args.scene, args.out, seed=args.seed, storage=args.storage, progress=True)
    print(
        f"wrote {args.out} ({len(data.torque)} torque samples, "
        f"{len(data.faults)} fault(s)) and {truth_path(args.out)}"
    )
    if args.plot:
        print(f"wrote {plot_bench_data(data, args.plot)}")
    return 0


def run(args: argparse.Namespace) -> int:
    """``bench-data``: for ``generate``, refuse a profile that leaves the envelope first."""
    if args.action == "generate":
        scene = load_bench_scene(args.scene)
        envelope = ValidityEnvelope.for_config(load_config(scene.config_path()))
        corners = [
            OperatingPoint(screw_speed=p.speed, temperature=p.temperature, preload=p.preload)
            for p in scene.profile
        ]
        refuse_outside(corners, envelope, scene.source or str(args.scene))
    return _run(args)
