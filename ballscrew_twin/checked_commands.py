"""Commands whose inputs are checked against the validity envelope before the module that does
the work runs (docs/model.md section 13): ``calibrate`` (targets of ``--data``) and
``bench-data generate`` (the scene's operating profile). Both refuse an input outside the
envelope with one line naming the file; a temperature column that reads as kelvin gets the
hint. Arguments and everything else are those of the wrapped modules.
"""

from __future__ import annotations

import argparse
from types import SimpleNamespace

from .calibration import add_arguments as calibrate_arguments
from .calibration import read_targets
from .calibration import run as calibrate_run
from .health import bench_data
from .health.bench_scene import load_bench_scene
from .models.base import OperatingPoint
from .models.validity import (
    CELSIUS_ZERO,
    ValidityEnvelope,
    kelvin_from_command_line,
    refuse_outside,
)
from .params import load_config


def run_calibrate(args: argparse.Namespace) -> int:
    """``calibrate``: refuse ``--data`` targets outside the envelope, then fit."""
    if args.data is not None:
        envelope = ValidityEnvelope.for_config(load_config(args.config))
        points = [target.point for target in read_targets(args.data)]
        for point in points:
            celsius = point.temperature - CELSIUS_ZERO
            kelvin_from_command_line(celsius, f"{args.data}: temperature_C", envelope)
        refuse_outside(points, envelope, str(args.data))
    return calibrate_run(args)


def run_bench_data(args: argparse.Namespace) -> int:
    """``bench-data``: for ``generate``, refuse a profile that leaves the envelope first."""
    if args.action == "generate":
        scene = load_bench_scene(args.scene)
        envelope = ValidityEnvelope.for_config(load_config(scene.config_path()))
        corners = [
            OperatingPoint(screw_speed=p.speed, temperature=p.temperature, preload=p.preload)
            for p in scene.profile
        ]
        refuse_outside(corners, envelope, scene.source or str(args.scene))
    return int(bench_data.run(args))


#: The commands as :mod:`ballscrew_twin.cli` wires them (``add_arguments`` and ``run``).
calibrate = SimpleNamespace(add_arguments=calibrate_arguments, run=run_calibrate)
bench_data_command = SimpleNamespace(add_arguments=bench_data.add_arguments, run=run_bench_data)
