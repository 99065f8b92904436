"""``ballscrew-twin bench contacts``: cost of one evaluation of every contact law, printed.

Three implementations of the same evaluation are timed on the same sphere states: the numpy
reference (:func:`ballscrew_twin.models.contact_forces.evaluate_contacts`), its compiled
drop-in (:func:`ballscrew_twin.kernels.contacts.evaluate_contacts_compiled`) and the raw
kernel it wraps (:func:`ballscrew_twin.kernels.contacts.contacts_kernel`, without building the
result's views). The states are the steady state of the paper's screw at 20 C / 100 rpm /
1500 N (symmetric mode, B = 2), and the same sphere states on all 50 azimuths of both nuts.
Median wall time per call, after compilation and warm-up; never asserted.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable
from functools import partial
from typing import Any, cast

import numba
import numpy as np

from ..kernels.contacts import contacts_kernel, evaluate_contacts_compiled, scene_arrays
from ..models.base import OperatingPoint
from ..models.contact_forces import evaluate_contacts, make_scene
from ..models.steady import SteadyStateModel
from ..params import load_config
from ..timing import median_time
from ..units import CELSIUS_ZERO, RPM

#: One-line help of this benchmark.
DESCRIPTION = "cost of one evaluation of the contact laws (numpy, compiled, raw kernel)"

#: Untimed calls of each case before timing (the first one compiles).
WARMUP_CALLS = 3


def report(repeat: int) -> str:
    """The timing table: median of ``repeat`` calls per implementation and sphere count."""
    config = load_config()
    point = OperatingPoint(screw_speed=100 * RPM, temperature=20 + CELSIUS_ZERO, preload=1500.0)
    model = SteadyStateModel(config, mode="symmetric")
    solution = model.solve(point)
    state = solution.state
    scene = make_scene(config, point.temperature, point.screw_speed)
    parameters = scene_arrays(scene)
    everywhere = model.ball_set("full")
    lines = [f"contact laws, median of {repeat} calls per case (numba {numba.__version__})"]
    for label, spheres, gravity in (
        ("B=2 ", np.array([0, 1]), solution.balls.gravity),
        ("B=50", everywhere.nut, everywhere.gravity),
    ):
        inputs = tuple(
            np.ascontiguousarray(values, dtype=np.float64)
            for values in (
                state.ball_nb[spheres],
                state.kinematics[spheres],
                state.nut_offset[spheres],
                gravity,
            )
        )
        no_velocity, no_approach_offset = np.zeros((0, 3)), np.zeros((0, 4))
        slide = np.zeros(len(inputs[0]))
        kernel = cast(Any, contacts_kernel)
        cases: tuple[tuple[str, Callable[[], object]], ...] = (
            ("reference evaluate_contacts", partial(evaluate_contacts, scene, *inputs)),
            ("evaluate_contacts_compiled", partial(evaluate_contacts_compiled, scene, *inputs)),
            (
                "contacts_kernel (raw)",
                partial(
                    kernel, *inputs, no_velocity, slide, no_approach_offset, False, *parameters
                ),
            ),
        )
        for name, call in cases:
            seconds = median_time(call, repeat, warmup=WARMUP_CALLS)
            lines.append(f"  {label} {name:<28} {seconds * 1e6:10.2f} us")
    return "\n".join(lines)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``bench contacts``."""
    parser.add_argument("--repeat", type=int, default=200, help="timed calls per case")


def run(args: argparse.Namespace) -> int:
    """Print the table."""
    print(report(args.repeat))
    return 0
