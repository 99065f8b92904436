"""``ballscrew-twin bench steady``: cost of the steady-state model, printed, never asserted.

Times, on this machine and in one run so that the numbers compare: one evaluation of all
contact laws for 2 and 50 spheres by the numpy reference and by the numba kernel, and one steady
solve (compiled backend) cold and warm-started at a nearby operating point, in symmetric and in
full mode.
"""

from __future__ import annotations

import argparse
from functools import partial
from typing import Literal

import numpy as np

from ..cli import CELSIUS_ZERO, RPM
from ..kernels.contacts import evaluate_contacts_compiled
from ..models.base import OperatingPoint
from ..models.contact_forces import evaluate_contacts, make_scene
from ..models.steady import SteadyStateModel
from ..params import TwinConfig, load_config
from ..timing import median_time

#: One-line help of this benchmark.
DESCRIPTION = "cost of the steady-state model (contact laws, cold and warm solves)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``bench steady``."""
    parser.add_argument("--config", default=None, help="parameter YAML (default: paper screw)")
    parser.add_argument("--repeat", type=int, default=20, help="repetitions of each timing")


def _bench_mode(
    config: TwinConfig,
    mode: Literal["symmetric", "full"],
    point: OperatingPoint,
    nearby: OperatingPoint,
    repeat: int,
) -> str:
    """One line of timings for one mode."""
    model = SteadyStateModel(config, mode=mode)
    solution = model.solve(point)
    state, balls = solution.state, solution.balls
    scene = make_scene(config, point.temperature, point.screw_speed)
    arguments = (scene, state.ball_nb, state.kinematics, state.nut_offset[balls.nut], balls.gravity)
    reference = median_time(partial(evaluate_contacts, *arguments), repeat)
    compiled = median_time(partial(evaluate_contacts_compiled, *arguments), repeat)

    def cold() -> None:
        model.forget_warm_start()
        model.solve(point)

    def warm() -> None:
        model.solve(point)
        model.solve(nearby)

    cold_time = median_time(cold, max(repeat // 4, 3))
    model.solve(point)
    warm_time = median_time(warm, max(repeat // 4, 3)) / 2.0
    count = len(balls.nut)
    return (
        f"  {mode:<9} {count:3d} spheres: contacts numpy {reference * 1e6:8.1f} us, "
        f"numba {compiled * 1e6:7.1f} us; solve cold {cold_time * 1e3:7.2f} ms, "
        f"warm {warm_time * 1e3:7.2f} ms"
    )


def run(args: argparse.Namespace) -> int:
    """Print the timings (median of ``--repeat`` runs)."""
    config = load_config(args.config)
    point = OperatingPoint(screw_speed=100 * RPM, temperature=20 + CELSIUS_ZERO, preload=1500.0)
    nearby = OperatingPoint(screw_speed=110 * RPM, temperature=21 + CELSIUS_ZERO, preload=1550.0)
    print(f"steady-state model cost, median of {args.repeat} runs, 20 C / 100 rpm / 1500 N")
    print(_bench_mode(config, "symmetric", point, nearby, args.repeat))
    print(_bench_mode(config, "full", point, nearby, args.repeat))
    print(f"  numpy {np.__version__}; targets of issue 3: warm full <= 100 us, symmetric <= 10 us")
    return 0
